r"""The floating base's position and velocity from an IMU and leg kinematics with contact.

A humanoid senses its joints (encoders) and its pelvis (an IMU: orientation, angular velocity,
specific force); where its base is and how fast it moves it must estimate. The standard filter
(Bloesch et al. 2013; the linear form used on many legged robots) integrates the accelerometer and
corrects with the legs in contact, whose soles do not move:

- **predict** (every sample, period :math:`\Delta`): the world acceleration of the base is the
  specific force rotated to the world plus gravity, :math:`a = R f + g`, and

  .. math:: p^+ = p + v\Delta + \tfrac12 a\Delta^2, \qquad v^+ = v + a\Delta,

  with process noise :math:`\sigma_a` on :math:`a` (the accelerometer's noise, its bias and the
  orientation's error, which leaks gravity into the horizontal);
- **correct** with each sole in contact: its velocity is zero, so the base moves at
  :math:`v = -(\omega \times R r + R\,\dot r)`, where :math:`r` is the sole's position in the base
  frame from the encoders and :math:`\dot r = J(q)\dot q` its velocity there; and it stays where it
  touched down, :math:`p = s - R r` with :math:`s` the sole's world position estimated at
  touchdown (leg odometry: the horizontal position drifts only at touchdowns; on a flat floor
  the sole's height is the floor's, and the height does not drift).

Both corrections are linear in the state :math:`x = (p, v)`, so the filter is a linear Kalman
filter with a time-varying measurement set. The kinematics that give :math:`r` and :math:`\dot r`
are the caller's (:mod:`robust_ismpc.sim.state_estimation` uses the robot's MuJoCo model); this
module is the filter alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.params import GRAVITY_MPS2
from ..exceptions import ParameterError
from ..validation import check_positive, check_vector

__all__ = ["BaseFilterParams", "BaseStateFilter"]

#: Gravity in the world frame [m/s²].
GRAVITY_VECTOR_MPS2 = np.array([0.0, 0.0, -GRAVITY_MPS2])


@dataclass(frozen=True)
class BaseFilterParams:
    """Noise model of the base filter (standard deviations).

    Attributes
    ----------
    acc_noise_mps2 : float
        σ of the world acceleration the accelerometer gives, per axis [m/s²]: its white noise plus
        what its bias and the orientation error make of gravity.
    leg_vel_noise_mps : float
        σ of the base velocity one sole in contact gives, per axis [m/s]: encoder velocity noise
        through the leg, and the sole's own small motions (rolling, slipping).
    leg_pos_noise_m : float
        σ of the base position one sole in contact gives, per axis [m].
    """

    acc_noise_mps2: float = 0.5
    leg_vel_noise_mps: float = 0.05
    leg_pos_noise_m: float = 0.005

    def __post_init__(self) -> None:
        check_positive("BaseFilterParams", acc_noise_mps2=self.acc_noise_mps2,
                       leg_vel_noise_mps=self.leg_vel_noise_mps, leg_pos_noise_m=self.leg_pos_noise_m)


class BaseStateFilter:
    """Kalman filter of the base position and velocity (world frame), see the module docstring.

    Parameters
    ----------
    params : BaseFilterParams
    period_s : float
        Δ, the period of :meth:`predict` [s].
    position_m : ndarray, shape (3,)
        Initial base position [m] (the robot starts where it is placed).
    velocity_mps : ndarray, shape (3,), optional
        Initial base velocity [m/s]; zero by default.
    floor_height_m : float, optional
        Height of the soles on a flat floor [m]: a sole touches down at that height, whatever the
        estimate says, so the vertical position does not drift from touchdown to touchdown.
        None: the estimate's height (uneven ground).
    """

    def __init__(self, params: BaseFilterParams, period_s: float, position_m: np.ndarray,
                 velocity_mps: np.ndarray | None = None, floor_height_m: float | None = None) -> None:
        if not isinstance(params, BaseFilterParams):
            raise ParameterError(f"params must be BaseFilterParams, got {type(params).__name__}")
        check_positive("BaseStateFilter", period_s=period_s)
        self.params = params
        self.period_s = float(period_s)
        self.position_m = check_vector("BaseStateFilter", "position_m", position_m, 3).copy()
        self.velocity_mps = (np.zeros(3) if velocity_mps is None
                             else check_vector("BaseStateFilter", "velocity_mps", velocity_mps, 3).copy())
        # the axes are independent and share one 2 x 2 covariance (position, velocity per axis)
        self.covariance = np.diag([params.leg_pos_noise_m**2, params.leg_vel_noise_mps**2])
        dt = self.period_s
        self._F = np.array([[1.0, dt], [0.0, 1.0]])
        g = np.array([0.5 * dt * dt, dt])
        self._Q = np.outer(g, g) * params.acc_noise_mps2**2
        self.floor_height_m = None if floor_height_m is None else float(floor_height_m)
        #: World position of each sole in contact, fixed at its touchdown [m]; key: the sole's name.
        self.anchors_m: dict[str, np.ndarray] = {}

    def predict(self, rotation: np.ndarray, specific_force_mps2: np.ndarray) -> None:
        """Advance one period with the accelerometer.

        Parameters
        ----------
        rotation : ndarray, shape (3, 3)
            The base's orientation (base to world) as the IMU gives it.
        specific_force_mps2 : ndarray, shape (3,)
            The accelerometer's reading in the base frame [m/s²] (acceleration minus gravity).
        """
        dt = self.period_s
        acc = rotation @ specific_force_mps2 + GRAVITY_VECTOR_MPS2
        self.position_m += self.velocity_mps * dt + 0.5 * dt * dt * acc
        self.velocity_mps += acc * dt
        self.covariance = self._F @ self.covariance @ self._F.T + self._Q

    def correct(self, rotation: np.ndarray, angular_velocity_radps: np.ndarray,
                soles_in_base_m: dict[str, np.ndarray], sole_velocities_in_base_mps: dict[str, np.ndarray]) -> None:
        """Correct with the soles in contact (none: nothing to correct; every anchor is dropped).

        Parameters
        ----------
        rotation : ndarray, shape (3, 3)
            Base orientation (base to world).
        angular_velocity_radps : ndarray, shape (3,)
            The base's angular velocity in the base frame [rad/s] (the gyroscope).
        soles_in_base_m, sole_velocities_in_base_mps : dict of str to ndarray (3,)
            Per sole in contact: its position r [m] and velocity J(q) q̇ [m/s] relative to the
            base, in the base frame, from the encoders. A sole absent from the dict is in the air;
            one that was absent at the previous call has just touched down and is anchored where
            the current estimate puts it.
        """
        for name in list(self.anchors_m):
            if name not in soles_in_base_m:
                del self.anchors_m[name]
        if not soles_in_base_m:
            return
        omega = np.asarray(angular_velocity_radps, dtype=float)
        p = self.params
        for name, r_base in soles_in_base_m.items():
            r_world = rotation @ r_base
            if name not in self.anchors_m:
                anchor = self.position_m + r_world
                if self.floor_height_m is not None:
                    anchor[2] = self.floor_height_m
                self.anchors_m[name] = anchor
            wx, wy, wz = omega.tolist()
            rx, ry, rz = r_base.tolist()
            lever = np.array([wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx])  # ω × r
            velocity = -(rotation @ (lever + sole_velocities_in_base_mps[name]))
            position = self.anchors_m[name] - r_world
            self._update(position, velocity, p.leg_pos_noise_m**2, p.leg_vel_noise_mps**2)

    def _update(self, position: np.ndarray, velocity: np.ndarray, var_pos: float, var_vel: float) -> None:
        """One Kalman update with a position and a velocity measurement of every axis
        (H = I per axis; the 2 × 2 algebra written out, as it runs at the physics rate)."""
        (a, b), (_, d) = self.covariance.tolist()
        s_pp, s_vv = a + var_pos, d + var_vel
        det = s_pp * s_vv - b * b
        # K = P S⁻¹ with S⁻¹ = [[s_vv, -b], [-b, s_pp]] / det
        k_pp, k_pv = (a * s_vv - b * b) / det, (a * -b + b * s_pp) / det
        k_vp, k_vv = (b * s_vv - d * b) / det, (-b * b + d * s_pp) / det
        innovation_p = position - self.position_m
        innovation_v = velocity - self.velocity_mps
        self.position_m += k_pp * innovation_p + k_pv * innovation_v
        self.velocity_mps += k_vp * innovation_p + k_vv * innovation_v
        self.covariance = np.array([[(1 - k_pp) * a - k_pv * b, (1 - k_pp) * b - k_pv * d],
                                    [-k_vp * a + (1 - k_vv) * b, -k_vp * b + (1 - k_vv) * d]])
