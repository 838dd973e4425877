"""``ismpc robot init|check``: draft a robot file from an MJCF scene, and stand and walk a robot."""

from __future__ import annotations

from pathlib import Path

from ..exceptions import ParameterError
from .common import _open_out, _warn, _write_run


def cmd_robot(args) -> int:
    """``ismpc robot init|check``."""
    from ..extras import require_extra

    if args.robot_command is None:
        raise ParameterError("ismpc robot needs a subcommand: init MODEL.xml --out FILE, or check FILE --out DIR")
    require_extra("sim", f"ismpc robot {args.robot_command}")
    if args.robot_command == "init":
        return _robot_init(args)
    require_extra("plot", "ismpc robot check (its gait.png)")
    return _robot_check(args)


def _robot_init(args) -> int:
    from ..io import atomic_write_bytes
    from ..sim.wizard import draft_robot, robot_file_text

    out = Path(args.out).expanduser()
    if out.suffix != ".toml":
        raise ParameterError(f"--out {args.out!r}: a robot file ends in .toml")
    if out.exists() and not args.overwrite:
        raise ParameterError(f"--out {args.out!r} exists; use --overwrite to replace it")
    out.parent.mkdir(parents=True, exist_ok=True)
    draft = draft_robot(args.model, args.left_foot, args.right_foot, args.name)
    atomic_write_bytes(out, robot_file_text(draft, out).encode())
    print(f"{draft.name}: {draft.mass_kg:.2f} kg, feet {draft.left_foot} / {draft.right_foot}, sole "
          f"{100 * draft.sole_length_m:.1f} x {100 * draft.sole_width_m:.1f} cm, {len(draft.leg_joints)} leg joints, "
          f"standing CoM {draft.com_height_m:.3f} m, feet {draft.foot_spacing_m:.3f} m apart, physics step "
          f"{1e3 * draft.physics_step_s:g} ms")
    for side, text in draft.sole_geometry.items():
        print(f"{side} sole from {text}")
    for note in draft.notes:
        _warn(note)
    if not args.no_calibrate:
        gain = _calibrate_draft(out)
        if gain is not None:
            atomic_write_bytes(out, robot_file_text(draft, out, swing_cop_gain_s2=gain).encode())
    print(f"wrote {out}; check it with: ismpc robot check {out} --out DIR")
    return 0


def _calibrate_draft(path: Path) -> float | None:
    """The swing-leg CoP gain of a drafted robot file, or None (with a warning) when the fit
    explains less than a third of the CoP deviation or fails."""
    from ..core.planner import WalkCommand, command_limits
    from ..exceptions import IsmpcError
    from ..sim.calibrate import fit_swing_cop_gain
    from ..sim.model import load_robot

    try:
        spec = load_robot(str(path))
        vx = 0.5 * command_limits(spec.params())["vx_mps"][0]
        fit = fit_swing_cop_gain(spec, WalkCommand(vx))
    except IsmpcError as exc:
        _warn(f"swing-leg CoP gain not calibrated: {exc}")
        return None
    explained = 1.0 - fit.rms_after_m / fit.rms_before_m if fit.rms_before_m > 0 else 0.0
    if explained < 1.0 / 3.0:
        _warn(f"swing-leg CoP gain not written: κ = {fit.gain_s2:.4f} s² explains only {explained:.0%} of the "
              f"forward CoP deviation ({100 * fit.rms_before_m:.2f} cm rms)")
        return None
    print(f"swing-leg CoP gain κ = {fit.gain_s2:.4f} s² (explains {explained:.0%} of the forward CoP deviation)")
    return fit.gain_s2


def _robot_check(args) -> int:
    from ..experiments.robot_check import check_robot
    from ..io import atomic_write_json
    from ..robots import robot_reference
    from ..sim.model import load_robot
    from ..sim.model_checks import physics_step_warning

    robot = robot_reference(args.file)
    coarse = physics_step_warning(load_robot(robot))  # before the run: the file is checked, and the warning comes first
    out = _open_out(args)
    if coarse:
        _warn(coarse)
    report, result = check_robot(robot, walk_s=args.walk_duration, vx_mps=args.vx)
    atomic_write_json(out / "check.json", report)
    _write_run(result, out, title=f"{report['robot_name']}: walk of `ismpc robot check`")
    stand, walk = report["stand"], report["walk"]
    held = "held" if stand["stood"] else f"FELL at {stand['fell_at_s']:.2f} s"
    print(f"{report['robot_name']}: stand {held} "
          f"(CoM drift {100 * stand['com_drift_m']:.1f} cm); walk at {walk['vx_mps']} m/s "
          f"{'FELL: ' + str(walk['failure']) if walk['fell'] else 'walked'} ({walk['distance_m']:.2f} m, "
          f"{walk['steps_taken']} steps, {walk['qp_infeasible_count']} infeasible QPs)")
    print(f"{'passed' if report['passed'] else 'FAILED'}; wrote {out / 'check.json'}, {out / 'gait.png'}")
    return 0 if report["passed"] else 3
