"""Draft a robot file from an MJCF model (``ismpc robot init``).

:func:`draft_robot` reads what a robot file needs from the model itself:

- the floating base (the body with the free joint, which must be the model's first body);
- the feet: the two feet (a jointed body and the bodies welded to it) whose geometry colliding
  with the floor reaches lowest in the model's first keyframe (or ``qpos0``), one each side of
  the base; or the bodies the user names (:mod:`robust_ismpc.sim.soles`);
- each sole: the points of that floor geometry, whichever body of the foot carries it, within
  :data:`~robust_ismpc.sim.soles.SOLE_TOLERANCE_M` of its lowest point along the foot frame's −z
  (box corners, sphere and capsule bottoms, cylinder rims, mesh vertices); the sole rectangle is
  the largest one inside their convex hull, and the hull is kept as the outline when it is
  larger. Visual geometry never makes a sole; a foot that has both says which was used;
- the leg joints: the joints from the base to each foot;
- a standing posture: whole-body IK with the soles flat on the floor at the keyframe's stance,
  the base level and the CoM over the middle of the soles at :data:`STANDING_HEIGHT_FRACTION`
  of its height with the keyframe's legs;
- the physics step: the model's own timestep, or 2 ms when that is coarse for torque control
  (:func:`~robust_ismpc.sim.model_checks.drafted_physics_step`);
- warnings: bodies whose inertia their size cannot hold (placeholders,
  :func:`~robust_ismpc.sim.model_checks.implausible_inertias`), legs that cannot move their sole
  in six directions, a standing IK that missed its targets.

:func:`robot_file_text` writes the draft as a commented TOML; the gait values are the size-scaled
defaults, spelled out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..exceptions import ModelError, ParameterError
from ..robots.spec import scaled_gait_defaults
from .model import _compile_model, has_floor
from .model_checks import drafted_physics_step, implausible_inertias
from .polygon import convex_hull
from .soles import SOLE_TOLERANCE_M, find_feet, foot_geometry, sole, sole_rotation
from .whole_body.ik import IkSettings

#: The standing CoM height as a fraction of the CoM height with the keyframe's legs (bent knees).
STANDING_HEIGHT_FRACTION = 0.92
#: The smallest sole side accepted [m]; less means a foot frame that is not parallel to its sole.
MIN_SOLE_SIDE_M = 0.02

_MOVING_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass
class RobotDraft:
    """What :func:`draft_robot` found; the fields of a robot file (docs/robots.md)."""

    name: str
    model_path: Path
    root_body: str
    left_foot: str
    right_foot: str
    sole_offset_m: dict[str, tuple[float, float, float]]
    sole_quat: dict[str, tuple[float, float, float, float]]
    sole_length_m: float
    sole_width_m: float
    sole_outline_m: list[tuple[float, float]]
    leg_joints: list[str]
    standing_posture: dict[str, float]
    com_height_m: float
    foot_spacing_m: float
    mass_kg: float
    physics_step_s: float
    model_timestep_s: float
    sole_geometry: dict[str, str] = field(default_factory=dict)
    placeholder_bodies: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def physics_step_note(self) -> str | None:
        """Why the drafted physics step is not the model's own timestep (None when it is)."""
        return drafted_physics_step(self.model_timestep_s)[1]


def _free_body(model: mujoco.MjModel) -> int:
    for j in range(model.njnt):
        if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
            body = int(model.jnt_bodyid[j])
            if body != 1:
                raise ModelError(f"the floating base {model.body(body).name!r} must be the model's first body")
            return body
    raise ModelError("the model has no free joint (floating base)")


def _leg_joints(model, root: int, foot: int) -> list[str]:
    chain, body = [], foot
    while body not in (0, root):
        chain.append(body)
        body = int(model.body_parentid[body])
    joints = [j for b in reversed(chain) for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
              if int(model.jnt_type[j]) in _MOVING_JOINTS]
    return [model.joint(j).name for j in joints]


def _stand(model, q0: np.ndarray, root: int, feet: dict[str, int], offsets: dict[str, np.ndarray],
           rotations: dict[str, np.ndarray], leg_joints: list[str],
           iterations: int = 400) -> tuple[np.ndarray, float, float, list[str]]:
    """Whole-body IK to a level, flat-footed, bent-knee stance; returns (qpos, CoM height,
    foot spacing, notes)."""
    import mink

    data = mujoco.MjData(model)
    data.qpos[:] = q0
    mujoco.mj_kinematics(model, data)
    soles = {}
    for side, body in feet.items():
        rot = data.xmat[body].reshape(3, 3)
        soles[side] = data.xpos[body] + rot @ offsets[side]
    ground = min(s[2] for s in soles.values())
    mujoco.mj_comPos(model, data)
    height = float(data.subtree_com[root][2] - ground) * STANDING_HEIGHT_FRACTION
    middle = 0.5 * (soles["left"] + soles["right"])
    heading = data.xmat[root].reshape(3, 3)[:, 0]
    yaw = math.atan2(heading[1], heading[0])
    level = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])

    conf = mink.Configuration(model, q0.copy())
    tasks = []
    for side, body in feet.items():
        task = mink.FrameTask(model.body(body).name, "body", position_cost=10.0, orientation_cost=10.0)
        body_rot = level @ rotations[side].T  # the sole level
        target = np.array([soles[side][0], soles[side][1], ground]) - body_rot @ offsets[side]
        task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(body_rot), target))
        tasks.append(task)
    com = mink.ComTask(cost=10.0)
    com.set_target(np.array([middle[0], middle[1], ground + height]))
    torso = mink.FrameTask(model.body(root).name, "body", position_cost=0.0, orientation_cost=5.0)
    torso.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(level), np.zeros(3)))
    # as the walking IK (wbik.IkSettings): the legs move freely, the rest keeps the keyframe's pose
    settings = IkSettings()
    cost = np.full(model.nv, settings.upper_body_posture_cost)
    for joint in leg_joints:
        cost[model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)]] = settings.posture_cost
    posture = mink.PostureTask(model, cost=cost)
    posture.set_target(q0)
    tasks += [com, torso, posture]
    limits = [mink.ConfigurationLimit(model)]
    for _ in range(iterations):
        velocity = mink.solve_ik(conf, tasks, 0.01, solver="daqp", damping=1e-3, limits=limits)
        conf.integrate_inplace(velocity, 0.01)
    q = conf.q.copy()
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    notes = []
    final = {side: data.xpos[b] + data.xmat[b].reshape(3, 3) @ offsets[side] for side, b in feet.items()}
    com_error = np.linalg.norm(data.subtree_com[root] - np.array([middle[0], middle[1], ground + height]))
    if com_error > 0.01:
        notes.append(f"the standing IK left the CoM {100 * com_error:.1f} cm from its target")
    for side, b in feet.items():
        tilt = math.degrees(math.acos(min(1.0, abs((data.xmat[b].reshape(3, 3) @ rotations[side])[2, 2]))))
        if tilt > 1.0:
            notes.append(f"the standing IK left the {side} foot tilted by {tilt:.1f} deg")
    spacing = abs(float((level.T @ (final["left"] - final["right"]))[1]))
    floor = 0.5 * (final["left"][2] + final["right"][2])
    return q, float(data.subtree_com[root][2] - floor), spacing, notes


def _bent_knee_starts(model, data, q0: np.ndarray, chains) -> list[np.ndarray]:
    """IK starting postures: the keyframe's, then with each knee bent 0.4 rad one way and the
    other (IK from straight legs cannot bend them: the CoM cannot move down there). A knee is a
    pitch joint (axis along the base's y) of a leg other than its first and last."""
    root_y = data.xmat[1].reshape(3, 3)[:, 1]
    bent = {1.0: q0.copy(), -1.0: q0.copy()}
    found = False
    for chain in chains:
        pitch = []
        for name in chain:
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            axis = data.xmat[model.jnt_bodyid[j]].reshape(3, 3) @ model.jnt_axis[j]
            if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE) and abs(axis @ root_y) > 0.9:
                pitch.append(j)
        for j in pitch[1:-1]:
            found = True
            low, high = model.jnt_range[j] if model.jnt_limited[j] else (-math.pi, math.pi)
            for sign, q in bent.items():
                q[model.jnt_qposadr[j]] = float(np.clip(q0[model.jnt_qposadr[j]] + 0.4 * sign, low, high))
    return [q0] + (list(bent.values()) if found else [])


def _leg_mobility_notes(model, q: np.ndarray, feet: dict[str, int], chains: dict[str, list[str]]) -> list[str]:
    """Notes for legs that cannot move their sole in all six directions relative to the base.

    With fewer, the sole cannot stay flat while the base moves over it (a leg without an ankle
    roll cannot shift the hips sideways over a flat foot), which a ZMP-based gait needs.
    """
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    names = ("forward", "sideways", "up", "roll", "pitch", "yaw")
    notes = []
    for side, body in feet.items():
        dofs = [int(model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)]) for j in chains[side]]
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacBody(model, data, jacp, jacr, body)
        jac = np.vstack([jacp, jacr])[:, dofs]
        u, sv, _ = np.linalg.svd(jac)
        rank = int(np.sum(sv > 1e-3 * sv.max())) if len(sv) else 0
        if rank < 6:
            missing = names[int(np.argmax(np.abs(u[:, -1])))]
            notes.append(
                f"the {side} leg moves its sole in {rank} of 6 directions relative to the base "
                f"({len(dofs)} joints; the missing one is mostly {missing}): with the sole flat the hips cannot move "
                "freely over it, and the robot is unlikely to walk (`ismpc robot check` tells)")
    return notes


def draft_robot(model_path: str | Path, left_foot: str | None = None, right_foot: str | None = None,
                name: str | None = None) -> RobotDraft:
    """Find in an MJCF scene what a robot file needs (module docstring).

    Raises
    ------
    ModelError
        No floor, no floating base (or not the first body), feet not found or without geometry,
        a sole smaller than :data:`MIN_SOLE_SIDE_M` (a foot frame not parallel to its sole).
    ParameterError
        Only one of ``left_foot`` / ``right_foot`` given.
    """
    path = Path(model_path).expanduser().resolve()
    if not path.is_file():
        raise ModelError(f"model file {str(model_path)!r} not found")
    model = _compile_model(str(path), path.stat().st_mtime, ())
    if not has_floor(model):
        raise ModelError("the model has no floor (a plane geom of the world body); "
                         "load the robot from a scene file that adds one")
    root = _free_body(model)
    data = mujoco.MjData(model)
    q0 = model.key_qpos[0].copy() if model.nkey else model.qpos0.copy()
    data.qpos[:] = q0
    mujoco.mj_kinematics(model, data)
    if (left_foot is None) != (right_foot is None):
        raise ParameterError("give both --left-foot and --right-foot, or neither")
    if left_foot is None:
        left, right = find_feet(model, data, root)
    else:
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in (left_foot, right_foot)]
        for n, i in zip((left_foot, right_foot), ids):
            if i < 0:
                raise ModelError(f"foot body {n!r} not found in the model {path}")
        left, right = ids
    feet = {"left": left, "right": right}
    offsets, sizes, outlines, rotations = {}, [], [], {}
    for side, body in feet.items():
        rotations[side] = sole_rotation(model, data, body, root)
        points, centre, length, width = sole(model, data, body, rotations[side])
        if min(length, width) < MIN_SOLE_SIDE_M:
            raise ModelError(
                f"{side} foot {model.body(body).name!r}: its lowest geometry along the frame's -z spans only "
                f"{100 * length:.1f} x {100 * width:.1f} cm; the foot frame is not parallel to the sole "
                "(add a site at the sole, aligned with it, and use foot_frame_type = \"site\")")
        offsets[side] = centre
        sizes.append((length, width))
        outlines.append(points)
    length = min(s[0] for s in sizes)
    width = min(s[1] for s in sizes)
    outline = [(round(float(x), 6), round(float(y), 6)) for x, y in convex_hull(outlines[0])]
    chains = (_leg_joints(model, root, left), _leg_joints(model, root, right))
    leg_joints = [j for j in chains[0] + chains[1] if j not in set(chains[0]) & set(chains[1])]  # not a waist
    q, com_height, spacing, notes = min(
        (_stand(model, start, root, feet, offsets, rotations, leg_joints)
         for start in _bent_knee_starts(model, data, q0, chains)),
        key=lambda result: len(result[3]),
    )
    notes = notes + _leg_mobility_notes(model, q, feet, dict(zip(("left", "right"), chains)))
    mass = float(model.body_subtreemass[root])
    placeholders = [b.describe(mass) for b in implausible_inertias(model)]
    physics_step, step_note = drafted_physics_step(float(model.opt.timestep))
    if step_note is not None:
        notes.append(f"{step_note}: the draft sets [simulation] physics_step_s = {physics_step:g}")
    notes += placeholders
    geometry = {side: foot_geometry(model, body) for side, body in feet.items()}
    posture = {}
    for j in range(model.njnt):
        if int(model.jnt_type[j]) in _MOVING_JOINTS:
            adr = model.jnt_qposadr[j]
            if abs(q[adr] - model.qpos0[adr]) > 1e-5:
                posture[model.joint(j).name] = round(float(q[adr]), 4)
    box_area = length * width
    hull_area = _polygon_area(outline)
    return RobotDraft(
        name=name or path.parent.name or path.stem,
        model_path=path,
        root_body=model.body(root).name,
        left_foot=model.body(left).name,
        right_foot=model.body(right).name,
        sole_offset_m={side: tuple(round(float(v), 4) for v in offsets[side]) for side in feet},
        sole_quat={side: _quaternion(rotations[side]) for side in feet}
        if any(not np.allclose(r, np.eye(3)) for r in rotations.values()) else {},
        sole_length_m=round(length, 4),
        sole_width_m=round(width, 4),
        sole_outline_m=outline if len(outline) >= 3 and box_area < 0.95 * hull_area else [],
        leg_joints=leg_joints,
        standing_posture=posture,
        com_height_m=com_height,
        foot_spacing_m=spacing,
        mass_kg=mass,
        physics_step_s=physics_step,
        model_timestep_s=float(model.opt.timestep),
        sole_geometry={side: f"{model.body(feet[side]).name}: {g.describe(model)}" for side, g in geometry.items()},
        placeholder_bodies=placeholders,
        notes=notes,
    )


def _quaternion(rotation: np.ndarray) -> tuple[float, float, float, float]:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).reshape(9))
    return tuple(round(float(q), 6) for q in quat)


def _polygon_area(points: list[tuple[float, float]]) -> float:
    if len(points) < 3:
        return 0.0
    xy = np.array(points)
    return 0.5 * abs(float(np.dot(xy[:, 0], np.roll(xy[:, 1], -1)) - np.dot(xy[:, 1], np.roll(xy[:, 0], -1))))


def _comment(text: str, prefix: str = "# ") -> list[str]:
    """``text`` as TOML comment lines of at most 100 characters."""
    import textwrap

    return textwrap.wrap(text, 100, initial_indent=prefix, subsequent_indent=prefix)


def robot_file_text(draft: RobotDraft, out_path: Path, swing_cop_gain_s2: float | None = None,
                    scene_additions: Sequence[str] = ()) -> str:
    """The robot file of ``draft`` as commented TOML; ``model`` relative to ``out_path``'s folder,
    or to an installed package's folder when the model lives in one. ``scene_additions``: what
    the scene writer added to a description (:attr:`~robust_ismpc.sim.description.WalkingScene.additions`),
    listed in the comments."""
    import importlib.util
    import os

    model_line = f'model = "{os.path.relpath(draft.model_path, out_path.parent.resolve())}"'
    for part in draft.model_path.parts:
        spec = importlib.util.find_spec(part) if part.isidentifier() else None
        if spec is not None and spec.submodule_search_locations:
            base = Path(next(iter(spec.submodule_search_locations))).resolve()
            if draft.model_path.is_relative_to(base):
                model_line = (f'model_package = "{part}"\n'
                              f'model = "{draft.model_path.relative_to(base).as_posix()}"')
                break

    gait = scaled_gait_defaults(draft.com_height_m, draft.sole_length_m, draft.sole_width_m, draft.foot_spacing_m)
    lines = [
        f"# {draft.name}: drafted by `ismpc robot init` from {draft.model_path.name}. Format: docs/robots.md.",
        "# Check it with `ismpc robot check THIS_FILE --out DIR` before you rely on it.",
    ]
    if scene_additions:
        lines += [f"# The model is the walking scene `ismpc robot init` wrote from {scene_additions[0]}; it added",
                  "# (see the comments at the top of the scene to change them):"]
        lines += [line for text in scene_additions[1:] for line in _comment(f"- {text}", "#   ")]
    if draft.placeholder_bodies:
        lines += _comment(f"WARNING: {len(draft.placeholder_bodies)} bodies have an inertia their geometry cannot "
                          f"hold (placeholders?); their mass counts in the robot's {draft.mass_kg:.2f} kg. Fix them "
                          "in the model (docs/robots.md):")
        lines += [line for text in draft.placeholder_bodies for line in _comment(text, "#   ")]
    lines += [
        f'name = "{draft.name}"',
        model_line,
        f'root_body = "{draft.root_body}"',
        f'torso_body = "{draft.root_body}"',
        'foot_frame_type = "body"',
        f'left_foot = "{draft.left_foot}"',
        f'right_foot = "{draft.right_foot}"',
        f"# The sole: the largest rectangle inside the foot's floor-colliding geometry within {1e3 * SOLE_TOLERANCE_M:g} mm of its",
        "# lowest point; the offset is its centre at ground level, in the foot frame. The geometry used:",
        *[line for side, text in draft.sole_geometry.items() for line in _comment(f"{side}: {text}", "#   ")],
        f"left_sole_offset_m = {list(draft.sole_offset_m['left'])}",
        f"right_sole_offset_m = {list(draft.sole_offset_m['right'])}",
    ]
    if draft.sole_quat:
        lines += ["# The soles are rotated from the foot bodies' frames (quaternion w, x, y, z in the body frame).",
                  f"left_sole_quat = {list(draft.sole_quat['left'])}",
                  f"right_sole_quat = {list(draft.sole_quat['right'])}"]
    lines += [
        f"sole_length_m = {draft.sole_length_m}",
        f"sole_width_m = {draft.sole_width_m}",
    ]
    if draft.sole_outline_m:
        lines += ["# The foot touches the floor beyond the rectangle: the convex hull of its lowest points.",
                  f"sole_outline_m = {[list(p) for p in draft.sole_outline_m]}"]
    lines += ["# The joints from the base to each foot.", "leg_joints = ["]
    lines += [f'  "{j}",' for j in draft.leg_joints] + ["]", ""]
    lines += [
        f"# Standing posture by whole-body IK: soles flat, base level, CoM {draft.com_height_m:.3f} m above the",
        f"# middle of the soles ({STANDING_HEIGHT_FRACTION:.0%} of its height with the keyframe's legs), feet "
        f"{draft.foot_spacing_m:.3f} m apart.",
        "[standing_posture]",
    ]
    lines += [f"{joint} = {angle}" for joint, angle in draft.standing_posture.items()]
    lines += [
        "",
        "# Gait: the defaults scaled on the robot's size (docs/robots.md), spelled out to edit.",
        "[gait]",
        f"T_ss_s = {gait['T_ss_s']}  # single support [s]",
        f"T_ds_s = {gait['T_ds_s']}  # double support [s]",
        f"zmp_box_x_m = {round(gait['zmp_box_x_m'], 4)}  # ZMP box, half the sole",
        f"zmp_box_y_m = {round(gait['zmp_box_y_m'], 4)}",
        f"kin_box_x_m = {round(gait['kin_box_x_m'], 4)}  # where the next footstep may land",
        f"kin_box_y_m = {round(gait['kin_box_y_m'], 4)}",
        f"max_yaw_step_rad = {gait['max_yaw_step_rad']}",
        f"swing_height_m = {gait['swing_height_m']}",
    ]
    if swing_cop_gain_s2 is not None:
        lines.append(f"swing_cop_gain_s2 = {swing_cop_gain_s2:.4f}  # measured by `ismpc calibrate`")
    lines += ["", "# Simulation: MuJoCo's physics step; the torque control solves its inverse dynamics at every one."]
    step_note = draft.physics_step_note
    if step_note is None:
        lines.append(f"# The model's own timestep ({1e3 * draft.model_timestep_s:g} ms), stated.")
    else:
        lines += _comment(f"Not the model's own: {step_note}. {1e3 * draft.physics_step_s:g} ms, as the built-in "
                          "robots.")
    lines += ["[simulation]", f"physics_step_s = {draft.physics_step_s:g}"]
    return "\n".join(lines) + "\n"
