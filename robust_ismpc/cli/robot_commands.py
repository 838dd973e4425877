"""``ismpc robot init|check``: draft a robot file from a URDF or MJCF model, and stand and walk a robot."""

from __future__ import annotations

from ..exceptions import ParameterError
from .common import _open_out, _warn, _write_run


def cmd_robot(args) -> int:
    """``ismpc robot init|check``."""
    from ..extras import require_extra

    if args.robot_command is None:
        raise ParameterError("ismpc robot needs a subcommand: init MODEL.urdf|MODEL.xml --out FILE, or check FILE --out DIR")
    require_extra("sim", f"ismpc robot {args.robot_command}")
    if args.robot_command == "init":
        return _robot_init(args)
    require_extra("plot", "ismpc robot check (its gait.png)")
    return _robot_check(args)


def _robot_init(args) -> int:
    from ..experiments.robot_init import init_robot

    result = init_robot(args.model, args.out, args.name, args.left_foot, args.right_foot, args.package_dir,
                        calibrate=not args.no_calibrate, overwrite=args.overwrite)
    draft, scene = result.draft, result.scene
    if scene is not None:
        print(f"wrote the walking scene {scene.path} for the {scene.kind.upper()} {scene.source.name}; added:")
        for line in scene.additions[1:]:
            print(f"  {line}")
    print(f"{draft.name}: {draft.mass_kg:.2f} kg, feet {draft.left_foot} / {draft.right_foot}, sole "
          f"{100 * draft.sole_length_m:.1f} x {100 * draft.sole_width_m:.1f} cm, {len(draft.leg_joints)} leg joints, "
          f"standing CoM {draft.com_height_m:.3f} m, feet {draft.foot_spacing_m:.3f} m apart, physics step "
          f"{1e3 * draft.physics_step_s:g} ms")
    for side, text in draft.sole_geometry.items():
        print(f"{side} sole from {text}")
    if result.cop_jitter_before_m is not None:
        print(f"standing CoP jitter {100 * result.cop_jitter_before_m:.1f} cm rms on the description's own feet: "
              f"box soles written instead, {100 * (result.cop_jitter_m or 0.0):.2f} cm rms")
    elif result.cop_jitter_m is not None:
        print(f"standing CoP jitter {100 * result.cop_jitter_m:.2f} cm rms (tick to tick)")
    if result.swing_cop_gain_s2 is not None:
        print(f"swing-leg CoP gain κ = {result.swing_cop_gain_s2:.4f} s²")
    for note in draft.notes + result.warnings:
        _warn(note)
    print(f"wrote {result.path}; check it with: ismpc robot check {result.path} --out DIR")
    return 0


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
    if stand["fell_at_s"] is not None:
        held = f"FELL at {stand['fell_at_s']:.2f} s"
    else:
        held = "held" if stand["stood"] else "DRIFTED (the CoM moved more than half a sole's width)"
    print(f"{report['robot_name']}: stand {held} "
          f"(CoM drift {100 * stand['com_drift_m']:.1f} cm); walk at {walk['vx_mps']} m/s "
          f"{'FELL: ' + str(walk['failure']) if walk['fell'] else 'walked'} ({walk['distance_m']:.2f} m, "
          f"{walk['steps_taken']} steps, {walk['qp_infeasible_count']} infeasible QPs)")
    walking = result.summary.get("model_diagnostics") or {}
    for when, contacts in (("standing", stand["diagnostics"]["self_contacts"]),
                           ("walking", walking.get("self_contacts", []))):
        if contacts and report["passed"]:
            _warn(f"self-contacts while {when}: " + ", ".join(
                f"{a} touches {b} ({c['max_force_n']:.1f} N)" for c in contacts for a, b in [c["bodies"]]))
    if not report["passed"]:
        for cause in report["causes"] or ["no cause measured: no self-contact, no jittery centre of pressure, no "
                                          "joint held at a torque or range limit, the CoM within the soles"]:
            print(f"likeliest cause: {cause}")
    print(f"{'passed' if report['passed'] else 'FAILED'}; wrote {out / 'check.json'}, {out / 'gait.png'}")
    return 0 if report["passed"] else 3
