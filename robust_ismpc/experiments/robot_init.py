"""``ismpc robot init``: from a model a robot ships with to a robot file that stands.

:func:`init_robot` takes a URDF, an MJCF robot (no floor or floating base) or an MJCF scene:

1. a description gets a walking scene written next to the robot file
   (:func:`~robust_ismpc.sim.description.write_walking_scene`);
2. the robot file is drafted from the scene (:func:`~robust_ismpc.sim.wizard.draft_robot`);
3. the robot stands still for :data:`STAND_CHECK_S` with the drafted file and the centre of
   pressure is measured (:func:`~robust_ismpc.experiments.robot_check.stand`). A CoP that jumps
   from tick to tick (more than :data:`~robust_ismpc.sim.diagnostics.COP_JITTER_SOLE_FRACTION` of
   the sole's width, rms) means the feet touch the floor through geometry that does not hold a flat
   contact: a scene written here is rewritten with a box sole on each foot, the drafted sole
   rectangle, in place of the foot's own colliding geometry, and measured again; a user's scene
   gets a warning with the figure and the box to add. Self-contacts in the standing posture are
   reported by name;
4. the swing-leg CoP gain is calibrated (:func:`~robust_ismpc.sim.calibrate.fit_swing_cop_gain`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..exceptions import IsmpcError, ParameterError
from ..io import atomic_write_bytes
from ..sim.description import SoleBox, WalkingScene, description_kind, write_walking_scene
from ..sim.diagnostics import COP_JITTER_SOLE_FRACTION
from ..sim.wizard import RobotDraft, draft_robot, robot_file_text

#: How long the drafted robot stands for the contact check [s].
STAND_CHECK_S = 1.0


@dataclass
class InitResult:
    """What :func:`init_robot` wrote and measured.

    Attributes
    ----------
    draft : RobotDraft
    path : Path
        The robot file.
    scene : WalkingScene or None
        The scene written for a description (None: the model was a scene).
    cop_jitter_m : float or None
        Standing CoP jitter with the drafted file [m] (rms tick-to-tick move).
    cop_jitter_before_m : float or None
        With the description's own feet, when box soles replaced them (else None) [m].
    self_contacts : list of dict
        Self-contacts while standing (bodies, max_force_n).
    swing_cop_gain_s2 : float or None
    warnings : list of str
    """

    draft: RobotDraft
    path: Path
    scene: WalkingScene | None
    cop_jitter_m: float | None = None
    cop_jitter_before_m: float | None = None
    self_contacts: list[dict] = field(default_factory=list)
    swing_cop_gain_s2: float | None = None
    warnings: list[str] = field(default_factory=list)


def sole_boxes(draft: RobotDraft) -> list[SoleBox]:
    """A box sole per foot: the drafted sole rectangle, at the drafted sole's place."""
    feet = {"left": draft.left_foot, "right": draft.right_foot}
    return [SoleBox(foot=body, centre_m=draft.sole_offset_m[side], quat=draft.sole_quat.get(side, (1.0, 0.0, 0.0, 0.0)),
                    length_m=draft.sole_length_m, width_m=draft.sole_width_m) for side, body in feet.items()]


def sole_box_snippet(box: SoleBox) -> str:
    """The MJCF geom of ``box`` to add to its foot body (its bottom face at the sole)."""
    half = 0.5 * box.thickness_m
    return (f'<geom name="{box.foot}_sole" type="box" size="{0.5 * box.length_m:.4f} {0.5 * box.width_m:.4f} {half:g}" '
            f'pos="{box.centre_m[0]:.4f} {box.centre_m[1]:.4f} {box.centre_m[2] + half:.4f}" '
            f'quat="{" ".join(f"{q:.4f}" for q in box.quat)}"/>')


def _write(draft: RobotDraft, path: Path, scene: WalkingScene | None, gain: float | None = None) -> None:
    text = robot_file_text(draft, path, swing_cop_gain_s2=gain, scene_additions=scene.additions if scene else ())
    atomic_write_bytes(path, text.encode())


def _standing(path: Path) -> dict:
    from ..sim.model import load_robot
    from .robot_check import stand

    return stand(load_robot(str(path)), STAND_CHECK_S)


def init_robot(model: str | Path, out: str | Path, name: str | None = None, left_foot: str | None = None,
               right_foot: str | None = None, package_dirs: Sequence[str | Path] = (), calibrate: bool = True,
               overwrite: bool = False) -> InitResult:
    """Write a robot file (and, for a description, its scene) for ``model`` (module docstring).

    Raises
    ------
    ParameterError
        ``out`` not a .toml, or the robot file or scene exists without ``overwrite``.
    ModelError
        From the scene writer and the wizard.
    """
    out = Path(out).expanduser()
    if out.suffix != ".toml":
        raise ParameterError(f"--out {str(out)!r}: a robot file ends in .toml")
    model_path = Path(model).expanduser()
    kind = description_kind(model_path) if model_path.is_file() else None
    scene_path = out.with_suffix(".xml")
    if model_path.is_file() and scene_path.resolve() == model_path.resolve():  # never over the description
        scene_path = out.with_name(f"{out.stem}_scene.xml")
    for path in (out, scene_path) if kind else (out,):
        if path.exists() and not overwrite:
            raise ParameterError(f"{str(path)!r} exists; use --overwrite to replace it")
    out.parent.mkdir(parents=True, exist_ok=True)
    scene = write_walking_scene(model_path, scene_path, package_dirs) if kind else None
    # a description's scene is named after the robot file (a URDF is often model.urdf)
    draft = draft_robot(scene_path if scene else model_path, left_foot, right_foot, name or (out.stem if kind else None))
    _write(draft, out, scene)
    result = InitResult(draft=draft, path=out, scene=scene)
    standing = _standing(out)
    jitter = standing["diagnostics"]["cop_jitter_m"]
    limit = COP_JITTER_SOLE_FRACTION * draft.sole_width_m
    if jitter is not None and jitter > limit:
        boxes = sole_boxes(draft)
        if scene is not None:
            result.cop_jitter_before_m = jitter
            scene = write_walking_scene(model_path, scene_path, package_dirs, sole_boxes=boxes)
            draft = draft_robot(scene_path, draft.left_foot, draft.right_foot, draft.name)
            _write(draft, out, scene)
            result.draft, result.scene = draft, scene
            standing = _standing(out)
            jitter = standing["diagnostics"]["cop_jitter_m"]
        else:
            result.warnings.append(
                f"standing still, the centre of pressure jumps by {100 * jitter:.1f} cm rms from one tick to the next "
                f"({jitter / draft.sole_width_m:.0%} of the sole's width; a flat sole: under "
                f"{100 * limit:.1f} cm): the feet touch the floor through geometry that does not hold a flat contact. "
                "Give each foot a box sole and switch off collisions of its other geoms, e.g.\n  "
                + "\n  ".join(sole_box_snippet(box) for box in boxes))
    result.cop_jitter_m = jitter
    result.self_contacts = standing["diagnostics"]["self_contacts"]
    for contact in result.self_contacts:
        a, b = contact["bodies"]
        result.warnings.append(f"self-contact in the standing posture: {a} touches {b} ({contact['max_force_n']:.1f} N)")
    if standing["fell_at_s"] is not None:
        result.warnings.append(f"the drafted robot fell at {standing['fell_at_s']:.2f} s standing still; "
                               f"`ismpc robot check {out}` says why")
    elif not standing["stood"]:
        result.warnings.append(f"standing still, the drafted robot's CoM drifted {100 * standing['com_drift_m']:.1f} cm; "
                               f"`ismpc robot check {out}` says why")
    if calibrate:
        result.swing_cop_gain_s2 = _calibrate(out, result.warnings)
        if result.swing_cop_gain_s2 is not None:
            _write(result.draft, out, result.scene, result.swing_cop_gain_s2)
    return result


def _calibrate(path: Path, warnings: list[str]) -> float | None:
    """The swing-leg CoP gain of a drafted robot file, or None (with a warning) when the fit
    explains less than a third of the CoP deviation or fails."""
    from ..core.planner import WalkCommand, command_limits
    from ..sim.calibrate import fit_swing_cop_gain
    from ..sim.model import load_robot

    try:
        spec = load_robot(str(path))
        vx = 0.5 * command_limits(spec.params())["vx_mps"][0]
        fit = fit_swing_cop_gain(spec, WalkCommand(vx))
    except IsmpcError as exc:
        warnings.append(f"swing-leg CoP gain not calibrated: {exc}")
        return None
    explained = 1.0 - fit.rms_after_m / fit.rms_before_m if fit.rms_before_m > 0 else 0.0
    if explained < 1.0 / 3.0:
        warnings.append(f"swing-leg CoP gain not written: κ = {fit.gain_s2:.4f} s² explains only {explained:.0%} of "
                        f"the forward CoP deviation ({100 * fit.rms_before_m:.2f} cm rms)")
        return None
    return fit.gain_s2


__all__ = ["STAND_CHECK_S", "InitResult", "init_robot", "sole_box_snippet", "sole_boxes"]
