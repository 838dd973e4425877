"""Parameters as frozen, validated dataclasses, and per-robot defaults.

Symbols of the specification (``shared/spec/robust-ismpc.md`` §1) map to field names as in the
notation table of ``docs/notation.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from ..exceptions import ParameterError
from ..validation import check_nonnegative, check_positive

GRAVITY_MPS2 = 9.81


@dataclass(frozen=True)
class RobotParams:
    """Reduced-model (LIP) description of a biped and its nominal gait.

    Attributes
    ----------
    name : str
        Identifier (``hrp4``, ``nao``, ``g1``, ``op3`` or a user name).
    mass_kg : float
        Total mass, used to turn forces [N] into CoM accelerations [m/s^2].
    com_height_m : float
        Constant CoM height h above the ground [m].
    zmp_box_x_m, zmp_box_y_m : float
        Full side lengths d_{z,x}, d_{z,y} of the ZMP admissible box, centred on the sole [m].
    kin_box_x_m, kin_box_y_m : float
        Full side lengths d_{a,x}, d_{a,y} of the kinematically admissible box for the next
        footstep, in the previous footstep's frame [m].
    foot_spacing_m : float
        Nominal lateral distance ℓ between consecutive footsteps [m].
    max_yaw_step_rad : float
        Largest yaw change θ_max between consecutive footsteps [rad].
    T_ss_s, T_ds_s : float
        Nominal single- and double-support durations [s].
    swing_height_m : float
        Apex height of the swing foot [m].
    sole_length_m, sole_width_m : float
        Physical sole rectangle (x and y sides) [m]; the ZMP box must fit inside it.
    swing_cop_gain_s2 : float
        κ [s²]: on a multibody robot the centre of pressure moves ``κ a`` from the LIP's ZMP while
        the swing foot accelerates forward with ``a`` [m/s²] (the swing leg's angular momentum);
        the MPC then keeps ``p + κ a`` in the ZMP box (:mod:`robust_ismpc.core.swing_cop`). 0
        (default): the LIP, whose ZMP is the CoP. Measure it with
        :func:`robust_ismpc.sim.calibrate.fit_swing_cop_gain`.
    """

    name: str
    mass_kg: float
    com_height_m: float
    zmp_box_x_m: float
    zmp_box_y_m: float
    kin_box_x_m: float
    kin_box_y_m: float
    foot_spacing_m: float
    max_yaw_step_rad: float
    T_ss_s: float
    T_ds_s: float
    swing_height_m: float
    sole_length_m: float
    sole_width_m: float
    swing_cop_gain_s2: float = 0.0

    def __post_init__(self) -> None:
        owner = f"RobotParams[{self.name}]"
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"RobotParams.name must be a non-empty string, got {self.name!r}")
        check_positive(
            owner,
            mass_kg=self.mass_kg,
            com_height_m=self.com_height_m,
            zmp_box_x_m=self.zmp_box_x_m,
            zmp_box_y_m=self.zmp_box_y_m,
            kin_box_x_m=self.kin_box_x_m,
            kin_box_y_m=self.kin_box_y_m,
            foot_spacing_m=self.foot_spacing_m,
            max_yaw_step_rad=self.max_yaw_step_rad,
            T_ss_s=self.T_ss_s,
            T_ds_s=self.T_ds_s,
            sole_length_m=self.sole_length_m,
            sole_width_m=self.sole_width_m,
        )
        check_nonnegative(owner, swing_height_m=self.swing_height_m, swing_cop_gain_s2=self.swing_cop_gain_s2)
        if self.zmp_box_x_m > self.sole_length_m + 1e-12 or self.zmp_box_y_m > self.sole_width_m + 1e-12:
            raise ParameterError(
                f"{owner}: ZMP box {self.zmp_box_x_m} x {self.zmp_box_y_m} m must fit inside the "
                f"sole {self.sole_length_m} x {self.sole_width_m} m"
            )
        if self.max_yaw_step_rad >= math.pi / 2:
            raise ParameterError(f"{owner}.max_yaw_step_rad must be < pi/2, got {self.max_yaw_step_rad}")

    @property
    def eta(self) -> float:
        """LIP natural frequency η = sqrt(g / h) [1/s]."""
        return math.sqrt(GRAVITY_MPS2 / self.com_height_m)

    @property
    def T_step_s(self) -> float:
        """Nominal step duration T_ss + T_ds [s]."""
        return self.T_ss_s + self.T_ds_s

    def with_values(self, **changes: Any) -> RobotParams:
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class MpcParams:
    """IS-MPC settings.

    Attributes
    ----------
    sampling_period_s : float
        δ, the MPC sampling interval and control period [s].
    control_horizon_s : float
        T_c = C δ [s].
    preview_horizon_s : float
        T_p = P δ >= T_c [s]; the anticipative tail covers (T_c, T_p].
    footstep_weight : float
        β, the weight on the deviation of footsteps from their candidates.
    zmp_centring_weight : float
        γ [1/s²], the weight on the ZMP's distance from the centre of its box at every sample of
        the control horizon, against 1 on the ZMP velocity (the cost
        ½‖Ẋ_z‖² + ½γ‖X_z − X_c‖² + ½β‖X_f − X̂_f‖², :mod:`robust_ismpc.core.mpc`). Without it
        nothing returns a standing robot's DCM to the middle of its feet: an estimate that lags
        a persistent force leaves the DCM where the lag put it, and the next lag adds to it.
        Default 100, the DIAG reference code's value (spec §7.2); 0: the paper's cost.
    tail : str
        ``"anticipative"`` (default), ``"periodic"`` or ``"truncated"``.
    fix_footsteps : bool
        If true the footsteps equal the candidates (β -> ∞) and are not decision variables.
    footstep_freeze_s : float
        The footstep being stepped on stops being a decision variable this long before
        touchdown [s], so that the swing foot has a fixed target at landing.
    max_fallback_cycles : int
        After an infeasible QP the controller plays the previous plan shifted by one sample, at
        most this many consecutive cycles, then reports a failure.
    solver : str
        ``"daqp"`` (default, called directly) or any qpsolvers backend name.
    """

    sampling_period_s: float = 0.01
    control_horizon_s: float = 1.0
    preview_horizon_s: float = 2.5
    footstep_weight: float = 1e4
    zmp_centring_weight: float = 100.0
    tail: str = "anticipative"
    fix_footsteps: bool = False
    footstep_freeze_s: float = 0.05
    max_fallback_cycles: int = 5
    solver: str = "daqp"

    def __post_init__(self) -> None:
        check_positive(
            "MpcParams",
            sampling_period_s=self.sampling_period_s,
            control_horizon_s=self.control_horizon_s,
            preview_horizon_s=self.preview_horizon_s,
            footstep_weight=self.footstep_weight,
        )
        check_nonnegative("MpcParams", footstep_freeze_s=self.footstep_freeze_s,
                          zmp_centring_weight=self.zmp_centring_weight)
        if self.tail not in ("anticipative", "periodic", "truncated"):
            raise ParameterError(
                f"MpcParams.tail must be one of anticipative, periodic, truncated; got {self.tail!r}"
            )
        if self.control_horizon_s < 2 * self.sampling_period_s:
            raise ParameterError(
                f"MpcParams.control_horizon_s ({self.control_horizon_s}) must span at least two "
                f"samples of {self.sampling_period_s} s"
            )
        if self.preview_horizon_s < self.control_horizon_s - 1e-12:
            raise ParameterError(
                f"MpcParams.preview_horizon_s ({self.preview_horizon_s}) must be >= "
                f"control_horizon_s ({self.control_horizon_s})"
            )
        if not isinstance(self.max_fallback_cycles, int) or self.max_fallback_cycles < 0:
            raise ParameterError(
                f"MpcParams.max_fallback_cycles must be an integer >= 0, got {self.max_fallback_cycles!r}"
            )
        for name in ("control_horizon_s", "preview_horizon_s"):
            ratio = getattr(self, name) / self.sampling_period_s
            if abs(ratio - round(ratio)) > 1e-6:
                raise ParameterError(
                    f"MpcParams.{name} ({getattr(self, name)}) must be a whole multiple of "
                    f"sampling_period_s ({self.sampling_period_s})"
                )

    @property
    def C(self) -> int:
        """Number of samples in the control horizon."""
        return int(round(self.control_horizon_s / self.sampling_period_s))

    @property
    def P(self) -> int:
        """Number of samples in the preview horizon."""
        return int(round(self.preview_horizon_s / self.sampling_period_s))

    def with_values(self, **changes: Any) -> MpcParams:
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)


def mpc_params_for(robot: RobotParams) -> MpcParams:
    """The default MPC settings for ``robot``: :class:`MpcParams` defaults, with the control
    horizon stretched to one step (on the sampling grid) and the preview horizon by as much, for
    a robot whose step is longer than the default control horizon (tall robots)."""
    base = MpcParams()
    if robot.T_step_s <= base.control_horizon_s + 1e-9:
        return base
    dt = base.sampling_period_s
    control = math.ceil(robot.T_step_s / dt - 1e-9) * dt
    return base.with_values(control_horizon_s=control,
                            preview_horizon_s=base.preview_horizon_s + control - base.control_horizon_s)


# Per-robot LIP-level defaults. hrp4 and nao follow T-RO 2020 (spec §16); the step timing is the
# T-RO cruise rule (1) evaluated at 0.3 m/s (T_s = 0.5 s, as in the T-RO MATLAB runs), split 60/40. g1 and op3 are derived
# from the published figures of the Unitree G1 (33.3 kg, sole about 0.17 x 0.05 m, bent-knee CoM
# height about 0.62 m) and the Robotis OP3 (about 3.1 kg); the MuJoCo layer reads mass and CoM
# height from the model files and overrides these.
ROBOT_DEFAULTS: dict[str, RobotParams] = {
    "hrp4": RobotParams(
        name="hrp4", mass_kg=40.0, com_height_m=0.78,
        zmp_box_x_m=0.04, zmp_box_y_m=0.04, kin_box_x_m=0.30, kin_box_y_m=0.07,
        foot_spacing_m=0.18, max_yaw_step_rad=math.pi / 8,
        T_ss_s=0.30, T_ds_s=0.20, swing_height_m=0.025,
        sole_length_m=0.25, sole_width_m=0.13,
    ),
    "nao": RobotParams(
        name="nao", mass_kg=5.4, com_height_m=0.23,
        zmp_box_x_m=0.03, zmp_box_y_m=0.03, kin_box_x_m=0.10, kin_box_y_m=0.05,
        foot_spacing_m=0.10, max_yaw_step_rad=math.pi / 8,
        T_ss_s=0.30, T_ds_s=0.20, swing_height_m=0.02,
        sole_length_m=0.16, sole_width_m=0.09,
    ),
    "g1": RobotParams(
        name="g1", mass_kg=33.3, com_height_m=0.62,
        zmp_box_x_m=0.08, zmp_box_y_m=0.03, kin_box_x_m=0.50, kin_box_y_m=0.10,
        foot_spacing_m=0.20, max_yaw_step_rad=0.30,
        T_ss_s=0.50, T_ds_s=0.20, swing_height_m=0.05,
        sole_length_m=0.17, sole_width_m=0.05,
    ),
    "op3": RobotParams(
        name="op3", mass_kg=3.1, com_height_m=0.24,
        zmp_box_x_m=0.04, zmp_box_y_m=0.03, kin_box_x_m=0.12, kin_box_y_m=0.05,
        foot_spacing_m=0.08, max_yaw_step_rad=0.30,
        T_ss_s=0.30, T_ds_s=0.15, swing_height_m=0.02,
        sole_length_m=0.11, sole_width_m=0.07,
    ),
}


def robot_params(name: str) -> RobotParams:
    """Return the built-in LIP parameters of robot ``name``.

    Raises
    ------
    ParameterError
        If ``name`` is not one of the built-in robots (the message lists them).
    """
    try:
        return ROBOT_DEFAULTS[name]
    except KeyError:
        raise ParameterError(
            f"unknown robot {name!r}; built-in robots are: {', '.join(sorted(ROBOT_DEFAULTS))} "
            "(or the path of a robot file, .toml)"
        ) from None


def field_names(cls: type) -> list[str]:
    """Names of a parameter dataclass's fields (for CLI and TOML validation)."""
    return [f.name for f in fields(cls)]
