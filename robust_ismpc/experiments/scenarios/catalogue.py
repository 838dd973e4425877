"""The paper's three experiments (§IV) as data: the scenario classes and the built-in registry.

Pure data: importing this module does not import MuJoCo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...control.modules import MODULES
from ...core.planner import WalkCommand
from ...exceptions import ParameterError
from ...runs.forces import ForceWindow
from ...validation import check_nonnegative, check_number, check_positive


@dataclass(frozen=True)
class PaperRobot:
    """The robot of a paper experiment, as far as a disturbance's scaling needs it.

    Attributes
    ----------
    name : str
        Name and where it ran (for documentation and ``details``).
    mass_kg : float
        Total mass [kg].
    com_height_m : float
        CoM height of the walking posture [m].
    sole_length_m : float
        Length of one sole [m].
    """

    name: str
    mass_kg: float
    com_height_m: float
    sole_length_m: float

    def __post_init__(self) -> None:
        check_positive("PaperRobot", mass_kg=self.mass_kg, com_height_m=self.com_height_m,
                       sole_length_m=self.sole_length_m)


#: HRP-4 as in the paper's DART simulation (the paper-push experiment): the DIAG URDF's mass
#: (40.05 kg), the robust IS-MPC C++ code's CoM height (0.71 m) and the URDF's sole collision box
#: (0.25 x 0.13 m); research spec §15.3 and §16.1 (docs/scenarios.md).
HRP4_DART = PaperRobot(name="HRP-4 (DART)", mass_kg=40.05, com_height_m=0.71, sole_length_m=0.25)


@dataclass(frozen=True)
class ScaledForce:
    r"""A force stated on the paper's robot, applied to the torso with the same dimensionless load.

    A force :math:`F` on a LIP of mass :math:`m` and CoM height :math:`h` is held, standing or
    walking, by a ZMP shifted by :math:`F h / (m g)` against it, which must stay inside the sole
    (half length :math:`\ell`). The scenario keeps the ratio of that shift to the sole the paper's:

    .. math:: \frac{F h}{m g \ell} = \frac{F_p h_p}{m_p g \ell_p}
              \quad\Rightarrow\quad
              F = F_p \, \frac{m}{m_p} \, \frac{h_p}{h} \, \frac{\ell}{\ell_p}

    (both components by the same factor, so the force keeps its direction). For a push shorter
    than :math:`1/\eta` the same factor keeps the DCM jump :math:`F \Delta t / (m \eta)` relative
    to the sole up to :math:`\sqrt{h_p / h}` (the duration is the paper's).

    Attributes
    ----------
    fx_n, fy_n : float
        Force on the paper's robot, world frame [N] (x forward = sagittal, y left = coronal).
    paper_robot : PaperRobot
        The robot the paper applied it to.
    t_start_s : float
        Start [s].
    duration_s : float
        Duration [s] (``inf``: until the end of the run).
    jitter : bool
        Subject to the scenario's seeded :class:`Variation` (time and magnitude).
    """

    fx_n: float
    fy_n: float
    paper_robot: PaperRobot
    t_start_s: float = 0.0
    duration_s: float = math.inf
    jitter: bool = False

    def __post_init__(self) -> None:
        check_number("ScaledForce", fx_n=self.fx_n)
        check_number("ScaledForce", fy_n=self.fy_n)
        if not isinstance(self.paper_robot, PaperRobot):
            raise ParameterError(f"ScaledForce.paper_robot must be a PaperRobot, got {self.paper_robot!r}")
        check_nonnegative("ScaledForce", t_start_s=self.t_start_s)
        if not (isinstance(self.duration_s, (int, float)) and self.duration_s > 0 and not math.isnan(self.duration_s)):
            raise ParameterError(f"ScaledForce.duration_s must be > 0 (inf allowed), got {self.duration_s!r}")

    def factor(self, robot_mass_kg: float, robot_com_height_m: float, robot_sole_length_m: float) -> float:
        r"""The scale factor :math:`(m/m_p)(h_p/h)(\ell/\ell_p)` onto a robot of the given mass [kg],
        standing CoM height [m] and sole length [m]."""
        check_positive("ScaledForce.factor", robot_mass_kg=robot_mass_kg, robot_com_height_m=robot_com_height_m,
                       robot_sole_length_m=robot_sole_length_m)
        p = self.paper_robot
        return (robot_mass_kg / p.mass_kg) * (p.com_height_m / robot_com_height_m) * (robot_sole_length_m / p.sole_length_m)

    def window(self, robot_mass_kg: float, robot_com_height_m: float, robot_sole_length_m: float,
               time_shift_s: float = 0.0, magnitude_scale: float = 1.0) -> ForceWindow:
        """The force on a robot of the given mass [kg], CoM height [m] and sole length [m]
        (:meth:`factor`), shifted [s] and scaled, as a ForceWindow."""
        k = self.factor(robot_mass_kg, robot_com_height_m, robot_sole_length_m) * magnitude_scale
        start = max(0.0, self.t_start_s + time_shift_s)
        return ForceWindow(k * self.fx_n, k * self.fy_n, start, start + self.duration_s)


@dataclass(frozen=True)
class BagSpec:
    """A bag (point mass on a rope with a free ball joint) hanging from a robot link.

    Attributes
    ----------
    reference_mass_kg : float
        Bag mass in the paper [kg] (scaled by ``robot mass / reference_robot_mass_kg``).
    reference_robot_mass_kg : float
        Mass of the paper's robot [kg].
    link : str or None
        Robot body it hangs from; None: the end of the right arm (:func:`right_arm_end`).
    attach_offset_m : tuple of 3 float
        Attachment point in the link frame [m].
    rope_length_m : float
        Attachment point to bag centre [m].
    radius_m : float
        Bag sphere radius (visual only, it does not collide) [m].
    initial_angle_rad : float
        Initial swing angle about the world y axis [rad] (seeded variation adds to it).
    damping_nms : float
        Ball-joint damping [N m s/rad].
    """

    reference_mass_kg: float = 0.67
    reference_robot_mass_kg: float = 5.4
    link: str | None = None
    attach_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rope_length_m: float = 0.10
    radius_m: float = 0.03
    initial_angle_rad: float = 0.0
    damping_nms: float = 0.0

    def __post_init__(self) -> None:
        for name in ("reference_mass_kg", "reference_robot_mass_kg", "rope_length_m", "radius_m"):
            check_positive("BagSpec", **{name: getattr(self, name)})
        check_number("BagSpec", initial_angle_rad=self.initial_angle_rad)
        check_nonnegative("BagSpec", damping_nms=self.damping_nms)
        if self.link is not None and not (isinstance(self.link, str) and self.link):
            raise ParameterError(f"BagSpec.link must be a body name or None, got {self.link!r}")
        offset = tuple(float(v) for v in self.attach_offset_m)
        if len(offset) != 3 or not all(math.isfinite(v) for v in offset):
            raise ParameterError(f"BagSpec.attach_offset_m must be 3 finite numbers, got {self.attach_offset_m!r}")
        object.__setattr__(self, "attach_offset_m", offset)


@dataclass(frozen=True)
class BallSpec:
    """A ball on a rope (pendulum) released so that it hits the robot's back at a planned instant.

    The hit is placed in the single support of the first step whose touchdown comes at least
    ``earliest_hit_s`` after the start, when the planned time to touchdown is
    ``time_to_step_at_hit_s`` (the paper: 0.25 s). The pivot is placed behind the torso at the
    reference CoM of that instant (the open-loop reference, which the robot follows until the
    hit), so that the ball touches the torso's back ``contact_angle_rad`` before the bottom of its
    swing; the release time is the hit time minus the pendulum's exact swing time from the
    release angle to the contact angle.

    Attributes
    ----------
    reference_mass_kg, reference_robot_mass_kg : float
        Ball mass and robot mass in the paper [kg]; the ball mass is scaled by the mass ratio.
    rope_length_m : float
        Pivot to ball centre [m].
    radius_m : float
        Ball radius [m].
    release_angle_rad : float
        Release angle from the vertical [rad]; sets the impact speed
        ``sqrt(2 g L (cos(contact) - cos(release)))``. Default: the horizontal (the paper gives no
        speed; a rope pendulum is released at most from there with its rope taut), 0.01 rad below
        it so that the force holding the ball until its release, ``m g tan(a)``, is finite
        (0.5 % less speed than from exactly horizontal).
    time_to_step_at_hit_s : float
        Planned remaining single support at the hit [s].
    earliest_hit_s : float
        The hit is in the first step whose touchdown is at least this late [s].
    hit_height_m : float or None
        Height of the ball centre at the hit [m]; None: middle of the torso's collision box.
    contact_angle_rad : float
        Angle of the rope from the vertical at first contact [rad] (> 0: before the bottom).
    """

    reference_mass_kg: float = 0.265
    reference_robot_mass_kg: float = 5.4
    rope_length_m: float = 0.5
    radius_m: float = 0.035
    release_angle_rad: float = 0.5 * math.pi - 0.01
    time_to_step_at_hit_s: float = 0.25
    earliest_hit_s: float = 3.0
    hit_height_m: float | None = None
    contact_angle_rad: float = 0.05

    def __post_init__(self) -> None:
        for name in ("reference_mass_kg", "reference_robot_mass_kg", "rope_length_m", "radius_m",
                     "time_to_step_at_hit_s", "earliest_hit_s"):
            check_positive("BallSpec", **{name: getattr(self, name)})
        check_nonnegative("BallSpec", contact_angle_rad=self.contact_angle_rad)
        check_positive("BallSpec", release_angle_rad=self.release_angle_rad)
        if not self.contact_angle_rad < self.release_angle_rad < 0.5 * math.pi - 1e-3:
            raise ParameterError(
                f"BallSpec.release_angle_rad must be in (contact angle, pi/2), got {self.release_angle_rad!r}"
            )
        if self.hit_height_m is not None:
            check_positive("BallSpec", hit_height_m=self.hit_height_m)


@dataclass(frozen=True)
class Variation:
    """Seeded random variation of the disturbances (seed 0 is the unvaried default).

    For seed > 0, a ``numpy.random.default_rng(seed)`` draws a time shift uniform in
    ``±time_s`` and a magnitude factor uniform in ``1 ± magnitude_fraction``, used by every
    jittered force, the ball (hit time, and impact speed through the rope length, which scales by
    the factor squared at the same release angle) and the bag (mass).

    Attributes
    ----------
    time_s : float
        Largest time shift [s].
    magnitude_fraction : float
        Largest relative magnitude change, in [0, 1).
    """

    time_s: float = 0.0
    magnitude_fraction: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative("Variation", time_s=self.time_s)
        check_nonnegative("Variation", magnitude_fraction=self.magnitude_fraction)
        if not self.magnitude_fraction < 1:
            raise ParameterError(f"Variation.magnitude_fraction must be < 1, got {self.magnitude_fraction!r}")

    def draw(self, seed: int) -> tuple[float, float]:
        """(time shift [s], magnitude factor) for ``seed``; (0, 1) for seed 0."""
        if seed == 0:
            return 0.0, 1.0
        rng = np.random.default_rng(seed)
        shift = float(rng.uniform(-self.time_s, self.time_s))
        scale = float(rng.uniform(1.0 - self.magnitude_fraction, 1.0 + self.magnitude_fraction))
        return shift, scale


@dataclass(frozen=True)
class Scenario:
    """One of the paper's experiments, stated as data.

    Attributes
    ----------
    name : str
        Identifier (``ismpc compare NAME``).
    summary : str
        One line for ``ismpc scenarios``.
    paper : str
        What the paper reports for this experiment (the expected outcome).
    robot : str
        Robot with a MuJoCo model: a built-in name or a robot file (:func:`on_robot` moves the
        scenario to another robot of a similar size).
    command : WalkCommand
        Velocity command (straight walks: the commanded path is the x axis through the start).
    duration_s : float
        Simulated time [s].
    robust_modules : tuple of str
        Modules of the robust side (the nominal side has none).
    forces : tuple of ScaledForce
        Forces on the torso, stated on the paper's robot.
    bag : BagSpec or None
    ball : BallSpec or None
    variation : Variation
        Seeded variation of time and magnitude.
    expect : str
        ``falls``: expected outcome = robust survives and nominal falls; ``deviates``: robust
        survives and nominal falls or deviates from the path (see :func:`expected_outcome`).
    """

    name: str
    summary: str
    paper: str
    robot: str
    command: WalkCommand
    duration_s: float
    robust_modules: tuple[str, ...]
    forces: tuple[ScaledForce, ...] = ()
    bag: BagSpec | None = None
    ball: BallSpec | None = None
    variation: Variation = field(default_factory=Variation)
    expect: str = "falls"

    def __post_init__(self) -> None:
        if not (isinstance(self.name, str) and self.name):
            raise ParameterError(f"Scenario.name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.command, WalkCommand):
            raise ParameterError(f"Scenario.command must be a WalkCommand, got {self.command!r}")
        check_positive("Scenario", duration_s=self.duration_s)
        unknown = [m for m in self.robust_modules if m not in MODULES]
        if unknown or not self.robust_modules:
            raise ParameterError(
                f"Scenario.robust_modules must be a non-empty subset of {', '.join(MODULES)}, got {self.robust_modules!r}"
            )
        for f in self.forces:
            if not isinstance(f, ScaledForce):
                raise ParameterError(f"Scenario.forces must hold ScaledForce, got {f!r}")
        if self.expect not in ("falls", "deviates"):
            raise ParameterError(f"Scenario.expect must be 'falls' or 'deviates', got {self.expect!r}")
        if self.ball is not None and abs(self.command.omega_radps) > 0:
            raise ParameterError("Scenario: the ball placement assumes a walk without turning")


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            name="paper-bag",
            summary="OP3 walks 0.15 m/s carrying a swinging bag (0.67 kg on 5.4 kg NAO, scaled) from its right elbow",
            paper="Fig. 2: robust leans against the load and keeps the path (timing never adapts); nominal "
            "deviates visibly from the straight path and almost falls",
            robot="op3",
            command=WalkCommand(0.15),
            duration_s=15.0,
            robust_modules=("observer", "restriction", "timing"),
            bag=BagSpec(),
            variation=Variation(time_s=0.0, magnitude_fraction=0.1),
            expect="deviates",
        ),
        Scenario(
            name="paper-ball",
            summary="OP3 walks 0.15 m/s and is hit from behind by a pendulum ball (0.265 kg on 5.4 kg NAO, scaled) "
            "0.25 s before touchdown",
            paper="Fig. 3: robust (timing adaptation only) shortens the time to step to 0.1 s and walks on; "
            "nominal becomes infeasible and falls",
            robot="op3",
            command=WalkCommand(0.15),
            duration_s=6.0,
            robust_modules=("timing",),
            ball=BallSpec(),
            variation=Variation(time_s=0.02, magnitude_fraction=0.1),
        ),
        Scenario(
            name="paper-push",
            summary="G1 (torque control) walks 0.2 m/s under a constant 45 N sagittal push from the start plus an "
            "85 N, 0.1 s coronal push (HRP-4 values, scaled to the same F h / (m g l))",
            paper="Fig. 4: robust (all modules) survives, timing adapts only right after the impulse; nominal falls",
            robot="g1",
            command=WalkCommand(0.2),
            duration_s=10.0,
            robust_modules=("observer", "restriction", "timing"),
            # "must walk under a constant push": the paper gives no start, so it is there from
            # t = 0 (a robot that walks under a push has stood under it; docs/scenarios.md).
            forces=(
                ScaledForce(45.0, 0.0, HRP4_DART, 0.0),
                ScaledForce(0.0, 85.0, HRP4_DART, 6.0, 0.1, jitter=True),
            ),
            variation=Variation(time_s=0.2, magnitude_fraction=0.1),
        ),
    )
}


def scenario_names() -> list[str]:
    """Names of the built-in scenarios."""
    return list(SCENARIOS)


def get_scenario(name: str) -> Scenario:
    """The built-in scenario ``name``.

    Raises
    ------
    ParameterError
        Unknown name (the message lists the valid ones).
    """
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ParameterError(f"unknown scenario {name!r}; scenarios are: {', '.join(SCENARIOS)}") from None
