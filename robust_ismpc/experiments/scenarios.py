"""The paper's three experiments (§IV) as named scenarios: data in one place, run side by side.

A :class:`Scenario` states an experiment in the paper's terms: the robot, the walk command, the
duration, the disturbances *as on the paper's robot* (a 0.67 kg bag on a 5.4 kg NAO, a 0.265 kg
ball, 45 N and 85 N on a 40 kg HRP-4) and which robustness modules the robust side uses.
:func:`realise` turns it into what one seed runs: disturbances scaled by the mass ratio of the
simulated robot, a small seeded variation of their time and magnitude, the two
:class:`~robust_ismpc.runs.spec.RunSpec` (nominal and robust) and the MuJoCo scene items (the bag,
the ball). :func:`run_scenario` runs both controllers on the identical disturbances and
:func:`comparison_metrics` condenses the pair into the ``comparison.json`` content.

Scaling rule: every mass and force is multiplied by ``m_robot / m_paper_robot`` (the measured
mass of the MuJoCo model over the paper robot's mass), so the disturbance *accelerations* match
the paper's. Lengths (rope, attachment) are chosen for the simulated robot's size.

Only :func:`realise` (robot mass, torso geometry) and :func:`run_scenario` need MuJoCo; they
import it lazily, so listing and validating scenarios does not.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ..control.modules import MODULES
from ..core.params import MpcParams
from ..core.planner import WalkCommand
from ..exceptions import ParameterError
from ..runs.forces import ForceWindow
from ..runs.spec import RunResult, RunSpec
from ..sim.model import compile_model
from ..validation import check_nonnegative, check_number, check_positive

GRAVITY_MPS2 = 9.81


@dataclass(frozen=True)
class ScaledForce:
    """A force stated on the paper's robot, applied to the torso after mass scaling.

    Attributes
    ----------
    fx_n, fy_n : float
        Force on the paper's robot, world frame [N] (x forward = sagittal, y left = coronal).
    reference_mass_kg : float
        Mass of the paper's robot the force was applied to [kg].
    t_start_s : float
        Start [s].
    duration_s : float
        Duration [s] (``inf``: until the end of the run).
    jitter : bool
        Subject to the scenario's seeded :class:`Variation` (time and magnitude).
    """

    fx_n: float
    fy_n: float
    reference_mass_kg: float
    t_start_s: float = 0.0
    duration_s: float = math.inf
    jitter: bool = False

    def __post_init__(self) -> None:
        check_number("ScaledForce", fx_n=self.fx_n)
        check_number("ScaledForce", fy_n=self.fy_n)
        check_positive("ScaledForce", reference_mass_kg=self.reference_mass_kg)
        check_nonnegative("ScaledForce", t_start_s=self.t_start_s)
        if not (isinstance(self.duration_s, (int, float)) and self.duration_s > 0 and not math.isnan(self.duration_s)):
            raise ParameterError(f"ScaledForce.duration_s must be > 0 (inf allowed), got {self.duration_s!r}")

    def window(self, robot_mass_kg: float, time_shift_s: float = 0.0, magnitude_scale: float = 1.0) -> ForceWindow:
        """The force on a robot of ``robot_mass_kg`` [kg], shifted and scaled, as a ForceWindow."""
        k = robot_mass_kg / self.reference_mass_kg * magnitude_scale
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
        ``sqrt(2 g L (cos(contact) - cos(release)))``.
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
    release_angle_rad: float = math.radians(60.0)
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
    jittered force, the ball (hit time and impact speed through the release angle) and the bag
    (mass).

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


#: Criterion of ``expect="deviates"``: the robust path deviation must stay below this (it keeps
#: the planned path), and the nominal one, unless it falls, must be at least this large and at
#: least :data:`DEVIATION_RATIO` times the robust one (stride-averaged CoM, see
#: :func:`path_deviation`).
DEVIATION_MIN_M = 0.03
DEVIATION_RATIO = 2.0

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
            summary="G1 (torque control) walks 0.2 m/s under a constant 45 N sagittal push plus an 85 N, 0.1 s "
            "coronal push (HRP-4 40 kg values, scaled)",
            paper="Fig. 4: robust (all modules) survives, timing adapts only right after the impulse; nominal falls",
            robot="g1",
            command=WalkCommand(0.2),
            duration_s=10.0,
            robust_modules=("observer", "restriction", "timing"),
            # The constant push starts once the robot walks (first single support at 2.6 s): from
            # a standing start no controller can hold it, not even one that knows the force
            # exactly (the lean it needs, w/η² = 7.1 cm, exceeds the standing ZMP box, ±4 cm, and
            # the first step is 2.6 s away; docs/scenarios.md).
            forces=(
                ScaledForce(45.0, 0.0, 40.0, 3.0),
                ScaledForce(0.0, 85.0, 40.0, 6.0, 0.1, jitter=True),
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


# ----------------------------------------------------------------------------------------------
# Realisation: one seed, masses and forces scaled, the ball placed.


@dataclass(frozen=True)
class ScenarioRun:
    """What one seed of a scenario runs.

    Attributes
    ----------
    scenario : Scenario
    seed : int
    nominal, robust : RunSpec
        The two runs (identical but for the modules).
    scene_items : tuple
        MuJoCo scene objects (:class:`~robust_ismpc.sim.scene.Payload`,
        :class:`~robust_ismpc.sim.scene.SwingingBall`).
    details : dict
        The realised values (scaled masses and forces, hit and release times), JSON-ready.
    """

    scenario: Scenario
    seed: int
    nominal: RunSpec
    robust: RunSpec
    scene_items: tuple
    details: dict


def pendulum_swing_time(rope_length_m: float, from_angle_rad: float, to_angle_rad: float,
                        gravity_mps2: float = GRAVITY_MPS2) -> float:
    r"""Time for a rod pendulum released at rest at ``from_angle_rad`` to reach ``to_angle_rad``.

    Integrates :math:`\ddot\theta = -(g/L)\sin\theta` exactly (no small-angle approximation);
    ``0 <= to < from < pi/2``.
    """
    from scipy.integrate import solve_ivp

    if not 0 <= to_angle_rad < from_angle_rad < 0.5 * math.pi:
        raise ParameterError(f"pendulum angles must satisfy 0 <= to < from < pi/2, got {to_angle_rad}, {from_angle_rad}")
    k = gravity_mps2 / rope_length_m

    def reach(_t, y):
        return y[0] - to_angle_rad

    reach.terminal = True
    reach.direction = -1
    sol = solve_ivp(lambda _t, y: [y[1], -k * math.sin(y[0])], (0.0, 10.0), [from_angle_rad, 0.0],
                    events=reach, rtol=1e-10, atol=1e-12, max_step=1e-3)
    return float(sol.t_events[0][0])


def _torso_back(robot_spec, com_xy: np.ndarray, height_m: float | None) -> tuple[float, float]:
    """(x offset of the torso's back from the CoM [m], hit height [m]) in the standing posture."""
    import mujoco

    from ..sim.loop import initial_state
    from ..sim.robot import standing_state

    model = compile_model(robot_spec)
    data = mujoco.MjData(model)
    standing_state(robot_spec, model, data)
    com, _, _ = initial_state(robot_spec)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot_spec.torso_body)
    boxes = []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != body or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        R = data.geom_xmat[g].reshape(3, 3)
        aabb = model.geom_aabb[g]
        centre = data.geom_xpos[g] + R @ aabb[:3]
        half = np.abs(R) @ aabb[3:]
        boxes.append((centre - half, centre + half))
    if not boxes:
        raise ParameterError(f"torso body {robot_spec.torso_body!r} has no collision geometry for the ball to hit")
    # The largest box is the trunk.
    lo, hi = max(boxes, key=lambda b: float(np.prod(b[1] - b[0])))
    z = 0.5 * (lo[2] + hi[2]) if height_m is None else height_m
    return float(lo[0] - com[0]), float(z)


def right_arm_end(robot_spec) -> str:
    """The body at the end of the robot's right arm, where the paper's bag hangs.

    In the standing posture: the highest body without children that lies more than 2 cm to the
    right of the base and is not on a leg (a foot or its parents).
    """
    import mujoco

    from ..sim.model import frame_body, frame_id
    from ..sim.robot import standing_state

    model = compile_model(robot_spec)
    data = mujoco.MjData(model)
    standing_state(robot_spec, model, data)
    mujoco.mj_kinematics(model, data)
    root = frame_id(model, "body", robot_spec.root_body, "root")
    legs = set()
    for name in (robot_spec.left_foot, robot_spec.right_foot):
        body = frame_body(model, robot_spec.foot_frame_type, frame_id(model, robot_spec.foot_frame_type, name, "foot"))
        while body > 0:
            legs.add(body)
            body = int(model.body_parentid[body])
    parents = set(int(p) for p in model.body_parentid[1:])
    in_base = (data.xpos - data.xpos[root]) @ data.xmat[root].reshape(3, 3)  # (nbody, 3), base frame
    ends = [(float(in_base[b, 2]), b) for b in range(1, model.nbody)
            if b not in parents and b not in legs and in_base[b, 1] < -0.02]
    if not ends:
        raise ParameterError(f"{robot_spec.name}: no right arm found for the bag (a childless body right of the base)")
    return model.body(max(ends)[1]).name


#: A scenario runs on a robot whose standing CoM height is within this factor of its own robot's.
SIZE_FACTOR = 2.0


def on_robot(scenario: Scenario, robot: str) -> Scenario:
    """``scenario`` on ``robot`` (a built-in name or a robot file) instead of its own.

    The disturbances scale with the robot's mass as on the scenario's own robot; the robot must
    be of a similar size: its standing CoM height within :data:`SIZE_FACTOR` of the scenario
    robot's.

    Raises
    ------
    ParameterError
        The robot is of another size (the message gives both heights), or unknown or invalid.
    """
    from ..sim.model import load_robot

    if robot == scenario.robot:
        return scenario
    own, other = load_robot(scenario.robot), load_robot(robot)
    ratio = other.com_height_m / own.com_height_m
    if not 1.0 / SIZE_FACTOR <= ratio <= SIZE_FACTOR:
        raise ParameterError(
            f"scenario {scenario.name} is for robots of {own.name}'s size (standing CoM {own.com_height_m:.2f} m, "
            f"within a factor {SIZE_FACTOR:g}); {other.name}'s CoM is at {other.com_height_m:.2f} m")
    return replace(scenario, robot=robot)


def _reference_com(robot_spec, spec: RunSpec, t_s: float) -> np.ndarray:
    """Reference CoM (x, y) of the nominal controller at ``t_s``, built as ``run_mujoco_spec`` does."""
    from ..control.walk import make_controller, start_walk
    from ..sim.loop import initial_state

    params = robot_spec.params()
    com0, left0, right0 = initial_state(robot_spec)
    yaw0 = 0.5 * (left0.yaw_rad + right0.yaw_rad)
    controller = make_controller(params, spec.mpc)
    plan = start_walk(controller, spec.command, spec.duration_s, left0.pos_m[:2], right0.pos_m[:2], yaw0, com0[:2])
    dt = spec.mpc.sampling_period_s
    reference = None
    for k in range(int(round(t_s / dt))):
        reference = controller.step(k * dt)
    return np.asarray(reference.com_pos_m[:2] if reference is not None else com0[:2], float), plan


def realise(scenario: Scenario | str, seed: int = 0, extra_forces: tuple[ForceWindow, ...] = (),
            mpc: MpcParams | None = None) -> ScenarioRun:
    """One seed of ``scenario``: scaled disturbances, run specs and scene items.

    Parameters
    ----------
    scenario : Scenario or str
    seed : int
        0: the scenario's values; > 0: varied by :class:`Variation`.
    extra_forces : tuple of ForceWindow
        Forces on the torso added to the scenario's own (``--force``/``--push``), unscaled.
    mpc : MpcParams, optional

    Raises
    ------
    ParameterError
        Unknown scenario, bad seed, or a ball that would have to be released before t = 0.
    """
    from ..sim.model import load_robot
    from ..sim.scene import Payload, SwingingBall

    if isinstance(scenario, str):
        scenario = get_scenario(scenario)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ParameterError(f"seed must be an integer >= 0, got {seed!r}")
    robot_spec = load_robot(scenario.robot)
    mass = float(robot_spec.mass_kg)
    shift, scale = scenario.variation.draw(seed)
    windows = tuple(
        f.window(mass, shift if f.jitter else 0.0, scale if f.jitter else 1.0) for f in scenario.forces
    ) + tuple(extra_forces)
    base = RunSpec(robot=scenario.robot, sim="mujoco", modules=(), command=scenario.command,
                   duration_s=scenario.duration_s, forces=windows, seed=seed,
                   mpc=mpc)
    details: dict = {
        "scenario": scenario.name, "seed": seed, "robot": scenario.robot, "robot_mass_kg": round(mass, 4),
        "time_shift_s": round(shift, 4), "magnitude_factor": round(scale, 4),
        "forces": [
            {"fx_n": round(w.fx_n, 4), "fy_n": round(w.fy_n, 4), "t_start_s": round(w.t_start_s, 4),
             "t_end_s": None if math.isinf(w.t_end_s) else round(w.t_end_s, 4)}
            for w in windows
        ],
    }
    items = []
    if scenario.bag is not None:
        bag = scenario.bag
        bag_mass = bag.reference_mass_kg * mass / bag.reference_robot_mass_kg * scale
        link = bag.link or right_arm_end(robot_spec)
        items.append(Payload(mass_kg=bag_mass, rope_length_m=bag.rope_length_m, link=link,
                             attach_offset_m=bag.attach_offset_m, radius_m=bag.radius_m,
                             initial_angle_rad=bag.initial_angle_rad, damping_nms=bag.damping_nms))
        details["bag"] = {"mass_kg": round(bag_mass, 4), "link": link, "rope_length_m": bag.rope_length_m}
    if scenario.ball is not None:
        ball = scenario.ball
        ball_mass = ball.reference_mass_kg * mass / ball.reference_robot_mass_kg
        # Magnitude variation acts on the impact speed: v ~ sqrt(1 - cos a).
        target = (1.0 - math.cos(ball.release_angle_rad)) * scale**2
        release_angle = math.acos(max(-1.0, min(1.0, 1.0 - target)))
        release_angle = min(release_angle, 0.5 * math.pi - 0.01)
        _, plan_probe = _reference_com(robot_spec, base, 0.0)
        td = plan_probe.touchdown_s
        js = [j for j in range(2, plan_probe.n_footsteps)
              if td[j] >= ball.earliest_hit_s and td[j] - ball.time_to_step_at_hit_s >= plan_probe.ss_start_s[j] - 1e-9]
        if not js:
            raise ParameterError("paper-ball: no step of the plan fits the hit; lengthen the scenario")
        j = js[0]
        hit_s = float(td[j] - ball.time_to_step_at_hit_s) + shift
        com_hit, _ = _reference_com(robot_spec, base, hit_s)
        back_dx, hit_z = _torso_back(robot_spec, com_hit, ball.hit_height_m)
        back_x = float(com_hit[0] + back_dx)
        L = ball.rope_length_m
        pivot = (back_x - ball.radius_m + L * math.sin(ball.contact_angle_rad), float(com_hit[1]),
                 hit_z + L * math.cos(ball.contact_angle_rad))
        swing_s = pendulum_swing_time(L, release_angle, ball.contact_angle_rad)
        release_s = hit_s - swing_s
        if release_s <= 0:
            raise ParameterError(f"paper-ball: the ball would have to be released at {release_s:.3f} s < 0")
        items.append(SwingingBall(pivot_m=pivot, rope_length_m=L, mass_kg=ball_mass, radius_m=ball.radius_m,
                                  release_angle_rad=release_angle, release_s=release_s))
        speed = math.sqrt(2 * GRAVITY_MPS2 * L * (math.cos(ball.contact_angle_rad) - math.cos(release_angle)))
        details["ball"] = {
            "mass_kg": round(ball_mass, 4), "rope_length_m": L, "radius_m": ball.radius_m,
            "release_angle_deg": round(math.degrees(release_angle), 3), "release_s": round(release_s, 4),
            "swing_s": round(swing_s, 4), "hit_s": round(hit_s, 4), "hit_step": j,
            "planned_touchdown_s": round(float(td[j]), 4),
            "time_to_step_at_hit_s": round(float(td[j]) - hit_s, 4),
            "pivot_m": [round(v, 4) for v in pivot], "expected_impact_speed_mps": round(speed, 4),
            "ball_momentum_ns": round(ball_mass * speed, 5),
        }
    return ScenarioRun(
        scenario=scenario, seed=seed, nominal=base, robust=replace(base, modules=scenario.robust_modules),
        scene_items=tuple(items), details=details,
    )


# ----------------------------------------------------------------------------------------------
# Metrics and running.


def path_deviation(trace, command: WalkCommand) -> dict:
    """Lateral distance of the CoM from the commanded straight path (the x axis through the start).

    The raw CoM sways by about a foot spacing every stride, so the deviation is also given for the
    CoM averaged over a sliding window of one stride (two steps): that is the "path" of Fig. 2.

    Returns
    -------
    dict
        ``max_m``, ``final_m`` (stride-averaged, absolute), ``final_signed_m`` (+ left),
        ``raw_max_m`` (raw CoM) [m]; None entries for a run shorter than one stride.
    """
    com = trace["com_m"]
    t = trace["t_s"]
    if len(t) < 2:
        return {"max_m": None, "final_m": None, "final_signed_m": None, "raw_max_m": None}
    heading = math.atan2(command.vy_mps, command.vx_mps) if (command.vx_mps or command.vy_mps) else 0.0
    normal = np.array([-math.sin(heading), math.cos(heading)])
    lateral = (com - com[0]) @ normal
    dt = float(t[1] - t[0])
    periods = np.diff(trace.footstep_touchdown_s[2:])
    stride = 2.0 * float(np.median(periods)) if periods.size else 1.0
    n = max(1, int(round(stride / dt)))
    if len(lateral) < n:
        return {"max_m": None, "final_m": None, "final_signed_m": None,
                "raw_max_m": round(float(np.max(np.abs(lateral))), 5)}
    averaged = np.convolve(lateral, np.ones(n) / n, mode="valid")
    return {
        "max_m": round(float(np.max(np.abs(averaged))), 5),
        "final_m": round(float(abs(averaged[-1])), 5),
        "final_signed_m": round(float(averaged[-1]), 5),
        "raw_max_m": round(float(np.max(np.abs(lateral))), 5),
    }


def _timing_after(trace, t_from: float, window_s: float = 0.5) -> dict:
    t = trace["t_s"]
    tts = trace["time_to_step_s"]
    adapted = np.nan_to_num(trace["timing_adapted"]) > 0
    mask = (t >= t_from - 1e-9) & (t <= t_from + window_s)
    first = np.flatnonzero(mask & adapted)
    planned = np.flatnonzero(mask)
    return {
        "time_to_step_at_hit_s": None if not planned.size else round(float(tts[planned[0]]), 4),
        "first_adaptation_s": None if not first.size else round(float(t[first[0]]), 4),
        "time_to_step_after_hit_s": None if not first.size else round(float(tts[first[0]]), 4),
        "min_time_to_step_after_hit_s": None if not first.size else round(float(np.min(tts[first])), 4),
        "adaptations_before_hit": int(np.count_nonzero(adapted & (t < t_from - 1e-9))),
        "adaptations_after_hit": int(np.count_nonzero(adapted & (t >= t_from - 1e-9))),
    }


def disturbance_events(run: ScenarioRun) -> list[tuple[str, float]]:
    """The disturbances of a realised scenario as (label, start time [s]), for figures.

    The planned ball hit, then every force window in time order ("push" when it ends,
    "constant force" when it lasts to the end of the run), labelled with its magnitude in N.
    """
    events = []
    if "ball" in run.details:
        events.append(("ball hit (planned)", float(run.details["ball"]["hit_s"])))
    for force in sorted(run.nominal.forces, key=lambda f: f.t_start_s):
        kind = "push" if math.isfinite(force.t_end_s) else "constant force"
        events.append((f"{kind} {math.hypot(force.fx_n, force.fy_n):.0f} N", float(force.t_start_s)))
    return events


def comparison_metrics(run: ScenarioRun, results: dict[str, RunResult]) -> dict:
    """``comparison.json`` content for a realised scenario and its two results.

    Per controller: who fell (and when), path deviation (:func:`path_deviation`), timing
    adaptations around the disturbance (the hit or the impulse), the disturbance estimate (mean
    over the last half of the run and final) against the applied mean, and what the scene items
    did (ball contact window and impulse, bag swing). ``expected_outcome`` applies the scenario's
    criterion (:func:`expected_outcome`).
    """
    scenario = run.scenario
    event_s = None
    if "ball" in run.details:
        event_s = run.details["ball"]["hit_s"]
    else:
        pushes = [f for f in run.nominal.forces if math.isfinite(f.t_end_s)]
        if pushes:
            event_s = min(p.t_start_s for p in pushes)
    out: dict = {"scenario": scenario.name, "seed": run.seed, "paper": scenario.paper, "realised": run.details}
    for label, result in results.items():
        s, trace = result.summary, result.trace
        t = trace["t_s"]
        half = t >= 0.5 * (t[-1] if len(t) else 0.0)
        w_est = trace["disturbance_est_mps2"][half]
        w_true = trace["disturbance_true_mps2"][half]
        entry = {
            "fell": s["fell"], "failure": s["failure"], "duration_s": s["duration_s"],
            "distance_m": s["distance_m"], "steps_taken": s["steps_taken"],
            "qp_infeasible_count": s["qp_infeasible_count"], "modules": s["modules"],
            "timing_adaptations": s["timing_adaptations"], "min_time_to_step_s": s["min_time_to_step_s"],
            "path_deviation": path_deviation(trace, scenario.command),
            "disturbance_estimate_mean_mps2": [round(float(v), 5) for v in np.nanmean(w_est, axis=0)] if w_est.size else None,
            "disturbance_estimate_final_mps2": s["disturbance_estimate_final"],
            "disturbance_applied_mean_mps2": [round(float(v), 5) for v in np.nanmean(w_true, axis=0)] if w_true.size else None,
        }
        if event_s is not None:
            entry["event_s"] = round(event_s, 4)
            entry.update(_timing_after(trace, event_s))
        if "scene" in s:
            entry["scene"] = s["scene"]
        out[label] = entry
    out["expected_outcome"] = expected_outcome(scenario, out)
    out["robust_survives_nominal_fails"] = bool(not out["robust"]["fell"] and out["nominal"]["fell"])
    robust = out["robust"]
    out["robust_keeps_path"] = (not robust["fell"] and robust["path_deviation"]["max_m"] is not None
                                and _keeps_path(robust))
    return out


def _keeps_path(run: dict) -> bool:
    """Whether a run's stride-averaged path deviation stays below :data:`DEVIATION_MIN_M`."""
    return (run["path_deviation"]["max_m"] or 0.0) < DEVIATION_MIN_M


def expected_outcome(scenario: Scenario, comparison: dict) -> bool:
    """Whether a comparison shows the paper's outcome.

    ``falls``: the robust run survives and the nominal one falls. ``deviates`` (the paper's
    Fig. 2: robust "accurately realizing the planned footsteps", nominal "a significant deviation
    from the planned path and almost leading to a fall"): the robust run survives and keeps the
    path (stride-averaged deviation below :data:`DEVIATION_MIN_M`), and the nominal one falls or
    deviates by at least :data:`DEVIATION_MIN_M` and :data:`DEVIATION_RATIO` times the robust one.
    """
    nominal, robust = comparison["nominal"], comparison["robust"]
    if robust["fell"]:
        return False
    if scenario.expect == "deviates" and not _keeps_path(robust):
        return False
    if nominal["fell"]:
        return True
    if scenario.expect == "falls":
        return False
    dn = nominal["path_deviation"]["max_m"] or 0.0
    return not _keeps_path(nominal) and dn >= DEVIATION_RATIO * (robust["path_deviation"]["max_m"] or 0.0)


@dataclass(frozen=True)
class ScenarioResult:
    """Both runs of a realised scenario and their comparison."""

    run: ScenarioRun
    results: dict
    comparison: dict


def run_scenario(
    scenario: Scenario | str,
    seed: int = 0,
    extra_forces: tuple[ForceWindow, ...] = (),
    duration_s: float | None = None,
    progress: Callable[[str], Callable[[float], None] | None] | None = None,
    video_dir=None,
    whole_body: str | None = None,
) -> ScenarioResult:
    """Run the nominal and the robust controller on one seed of ``scenario`` in MuJoCo.

    Parameters
    ----------
    scenario : Scenario or str
    seed : int
    extra_forces : tuple of ForceWindow
        Added to the scenario's forces.
    duration_s : float, optional
        Override the scenario's duration [s].
    progress : callable, optional
        ``progress(label)`` returns the per-run progress callback (or None).
    video_dir : path, optional
        Write ``video_dir/<label>/video.mp4`` for each run.
    whole_body : str or None
        ``servo`` or ``torque`` (:attr:`~robust_ismpc.runs.spec.RunSpec.whole_body`); None (default):
        the run specs' default.
    """
    from pathlib import Path

    from ..runs.mujoco import run_mujoco_spec

    if isinstance(scenario, str):
        scenario = get_scenario(scenario)
    if duration_s is not None:
        scenario = replace(scenario, duration_s=duration_s)
    realised = realise(scenario, seed, extra_forces)
    results = {}
    for label, spec in (("nominal", realised.nominal), ("robust", realised.robust)):
        if whole_body is not None:
            spec = replace(spec, whole_body=whole_body)
        video = None
        if video_dir is not None:
            (Path(video_dir) / label).mkdir(parents=True, exist_ok=True)
            video = Path(video_dir) / label / "video.mp4"
        callback = progress(label) if progress is not None else None
        result = run_mujoco_spec(spec, progress=callback, video_path=video, scene_items=realised.scene_items)
        result.trace.meta["scenario"] = scenario.name
        result.summary["scenario"] = scenario.name
        results[label] = result
    comparison = comparison_metrics(realised, results)
    comparison["whole_body"] = results["nominal"].summary["whole_body"]
    return ScenarioResult(run=realised, results=results, comparison=comparison)
