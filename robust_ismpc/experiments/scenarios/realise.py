"""Realisation of a scenario on a robot: scaled disturbances, the two run specs and the MuJoCo scene items."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...core.params import MpcParams
from ...exceptions import ParameterError
from ...runs.forces import ForceWindow
from ...runs.spec import RunSpec
from .catalogue import Scenario, get_scenario

GRAVITY_MPS2 = 9.81


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

    from ...sim.loop import initial_state
    from ...sim.model import compile_model
    from ...sim.robot import standing_state

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

    from ...sim.model import compile_model, frame_body, frame_id
    from ...sim.robot import standing_state

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


def _lateral_offset_m(robot_spec, link: str, offset_m) -> float:
    """Horizontal distance [m] of the point ``offset_m`` (``link`` frame) from the base's sagittal
    plane in the standing posture: the lever of a load hanging there."""
    import mujoco

    from ...sim.model import compile_model, frame_id
    from ...sim.robot import standing_state

    model = compile_model(robot_spec)
    data = mujoco.MjData(model)
    standing_state(robot_spec, model, data)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link)
    if body < 0:
        raise ParameterError(f"{robot_spec.name}: no body {link!r} to hang the bag from")
    root = frame_id(model, "body", robot_spec.root_body, "root")
    point = data.xpos[body] + data.xmat[body].reshape(3, 3) @ np.asarray(offset_m, float)
    in_base = data.xmat[root].reshape(3, 3).T @ (point - data.xpos[root])
    return float(abs(in_base[1]))


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
    from ...sim.model import load_robot

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
    from ...control.walk import make_controller, start_walk
    from ...sim.loop import initial_state

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


def check_load_factor(load_factor) -> float:
    """``load_factor`` as a float when it is a finite number > 0 (:func:`realise`), else ParameterError."""
    if isinstance(load_factor, bool) or not (isinstance(load_factor, (int, float)) and math.isfinite(load_factor)
                                             and load_factor > 0):
        raise ParameterError(f"load_factor must be a finite number > 0, got {load_factor!r}")
    return float(load_factor)


def realise(scenario: Scenario | str, seed: int = 0, extra_forces: tuple[ForceWindow, ...] = (),
            mpc: MpcParams | None = None, load_factor: float = 1.0) -> ScenarioRun:
    """One seed of ``scenario``: scaled disturbances, run specs and scene items.

    Parameters
    ----------
    scenario : Scenario or str
    seed : int
        0: the scenario's values; > 0: varied by :class:`Variation`.
    extra_forces : tuple of ForceWindow
        Forces on the torso added to the scenario's own (``--force``/``--push``), unscaled.
    mpc : MpcParams, optional
    load_factor : float
        The scenario's own disturbances times this (> 0; 1: the scenario): the bag's and the
        ball's masses (the ball at the same speed, so its momentum) and the forces' magnitudes.
        The axis of a frontier (``benchmarks/scenario_frontier.py``); ``extra_forces`` are not
        scaled.

    Raises
    ------
    ParameterError
        Unknown scenario, bad seed or load factor, or a ball that would have to be released
        before t = 0.
    """
    from ...sim.model import load_robot
    from ...sim.scene import Payload, SwingingBall

    if isinstance(scenario, str):
        scenario = get_scenario(scenario)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ParameterError(f"seed must be an integer >= 0, got {seed!r}")
    load_factor = check_load_factor(load_factor)
    robot_spec = load_robot(scenario.robot)
    mass = float(robot_spec.mass_kg)
    shift, scale = scenario.variation.draw(seed)
    com_height, sole_length = float(robot_spec.com_height_m), float(robot_spec.sole_length_m)
    windows = tuple(
        f.window(mass, com_height, sole_length, shift if f.jitter else 0.0,
                 (scale if f.jitter else 1.0) * load_factor)
        for f in scenario.forces
    ) + tuple(extra_forces)
    base = RunSpec(robot=scenario.robot, sim="mujoco", modules=(), command=scenario.command,
                   duration_s=scenario.duration_s, forces=windows, seed=seed,
                   mpc=mpc)
    details: dict = {
        "scenario": scenario.name, "seed": seed, "robot": scenario.robot, "robot_mass_kg": round(mass, 4),
        "robot_com_height_m": round(com_height, 4), "robot_sole_length_m": round(sole_length, 4),
        "time_shift_s": round(shift, 4), "magnitude_factor": round(scale, 4), "load_factor": load_factor,
        "force_factor": [round(f.factor(mass, com_height, sole_length), 5) for f in scenario.forces],
        "forces": [
            {"fx_n": round(w.fx_n, 4), "fy_n": round(w.fy_n, 4), "t_start_s": round(w.t_start_s, 4),
             "t_end_s": None if math.isinf(w.t_end_s) else round(w.t_end_s, 4)}
            for w in windows
        ],
    }
    items = []
    if scenario.bag is not None:
        bag = scenario.bag
        bag_mass = bag.reference_mass_kg * mass / bag.reference_robot_mass_kg * scale * load_factor
        link = bag.link or right_arm_end(robot_spec)
        lever = _lateral_offset_m(robot_spec, link, bag.attach_offset_m)
        items.append(Payload(mass_kg=bag_mass, rope_length_m=bag.rope_length_m, link=link,
                             attach_offset_m=bag.attach_offset_m, radius_m=bag.radius_m,
                             initial_angle_rad=bag.initial_angle_rad, damping_nms=bag.damping_nms))
        details["bag"] = {"mass_kg": round(bag_mass, 4), "link": link, "rope_length_m": bag.rope_length_m,
                          "lever_m": round(lever, 4)}
    if scenario.ball is not None:
        ball = scenario.ball
        ball_mass = ball.reference_mass_kg * mass / ball.reference_robot_mass_kg * load_factor
        # Magnitude variation acts on the impact speed through the rope length (v ~ sqrt(L)), so
        # the ball is released from the same angle on every seed.
        release_angle = ball.release_angle_rad
        L = ball.rope_length_m * scale**2
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
            "mass_kg": round(ball_mass, 4), "rope_length_m": round(L, 4), "radius_m": ball.radius_m,
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

