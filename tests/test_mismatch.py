"""Model mismatch: the simulated robot differs from the controller's model (robots/mismatch.py, sim/mismatch.py)."""

from __future__ import annotations

import numpy as np
import pytest

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.robots.mismatch import NO_MISMATCH, ModelMismatch, parse_mismatch
from robust_ismpc.runs.spec import RunSpec


def test_parse_reads_each_key_and_leaves_the_others_as_modelled():
    m = parse_mismatch(["mass=1.1", "payload=3.3@0.05,0,0.1"])
    assert m == ModelMismatch(mass_scale=1.1, payload_kg=3.3, payload_offset_m=(0.05, 0.0, 0.1))
    assert parse_mismatch(["motor=0.8"]).motor_strength == 0.8
    assert parse_mismatch(["payload=2"]).payload_offset_m == (0.0, 0.0, 0.0)
    assert parse_mismatch([]) == NO_MISMATCH and NO_MISMATCH.is_none


@pytest.mark.parametrize("items, match", [
    (["mass"], "expected"), (["weight=2"], "expected"), (["mass=x"], "not a number"), (["mass=nan"], "finite"),
    (["mass=1.1", "mass=1.2"], "twice"), (["payload=1@0,0"], "three numbers"), (["mass=0"], "> 0"),
    (["payload=-1"], ">= 0"), (["motor=-0.5"], "> 0"),
])
def test_bad_mismatch_items_raise(items, match):
    with pytest.raises(ParameterError, match=match):
        parse_mismatch(items)


def test_the_reduced_model_refuses_a_mismatch():
    with pytest.raises(ParameterError, match="needs --sim mujoco"):
        RunSpec(sim="lip", mismatch=ModelMismatch(mass_scale=1.1))


mujoco = pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation  # noqa: E402
from robust_ismpc.sim.model import load_robot  # noqa: E402
from robust_ismpc.sim.scene import LOAD_BODY  # noqa: E402


def _sim(mismatch: ModelMismatch) -> MujocoSimulation:
    return MujocoSimulation(load_robot("g1"), settings=LoopSettings(), mismatch=mismatch)


def test_the_simulated_robot_changes_and_the_measurement_keeps_the_model():
    """Masses scaled and a payload added in the physics; the robot's measured mass and CoM are
    the model's (the controller does not know), while the physics carries the extra weight."""
    plain, changed = _sim(NO_MISMATCH), _sim(ModelMismatch(mass_scale=1.1, payload_kg=2.0,
                                                            payload_offset_m=(0.0, 0.05, 0.0)))
    assert changed.robot.mass_kg == pytest.approx(plain.robot.mass_kg)
    np.testing.assert_allclose(changed.robot.com_position(), plain.robot.com_position(), atol=1e-9)
    ids = changed.robot.robot_body_ids
    np.testing.assert_allclose(changed.model.body_mass[ids], 1.1 * plain.model.body_mass[ids])
    load = mujoco.mj_name2id(changed.model, mujoco.mjtObj.mjOBJ_BODY, LOAD_BODY)
    assert load not in ids and changed.model.body_mass[load] == pytest.approx(2.0)
    # the feet carry the true weight: scaled robot plus payload
    for _ in range(20):
        mujoco.mj_step(changed.model, changed.data)
    weight = np.sum(changed.model.body_mass[1:]) * 9.81
    assert weight == pytest.approx((1.1 * plain.robot.mass_kg + 2.0) * 9.81, rel=1e-6)


def test_the_feet_weigh_what_the_robot_carries():
    """Standing 8 s (four weighing time constants), the mass the contact force is divided by
    goes from the model's to the robot's plus its payload, and stays the model's without one."""
    from robust_ismpc.estimation.weight import WEIGHING_TIME_CONSTANT_S

    plain, loaded = _sim(NO_MISMATCH), _sim(ModelMismatch(payload_kg=3.3))
    model_kg = plain.robot.mass_kg
    assert loaded.weighed_mass_kg == pytest.approx(model_kg)
    seconds = 4 * WEIGHING_TIME_CONSTANT_S
    for sim in (plain, loaded):
        for _ in range(round(seconds / sim.settings.control_period_s)):
            sim.advance()
    assert plain.weighed_mass_kg == pytest.approx(model_kg, rel=0.01)
    assert loaded.weighed_mass_kg == pytest.approx(model_kg + 3.3 * (1 - np.exp(-4)), rel=0.01)
    measurement, _ = loaded.measure()
    force = loaded.mean_horizontal_contact_force_n
    np.testing.assert_allclose(measurement.contact_acc_mps2, force / loaded.weighed_mass_kg)


def test_motor_strength_scales_the_torque_the_motors_deliver():
    from robust_ismpc.sim.whole_body.inverse_dynamics import TorqueControlSettings

    settings = LoopSettings(torque_control=TorqueControlSettings())
    plain = MujocoSimulation(load_robot("g1"), settings=settings)
    weak = MujocoSimulation(load_robot("g1"), settings=settings, mismatch=ModelMismatch(motor_strength=0.8))
    for sim in (plain, weak):
        sim.data.ctrl[:] = 1.0
        mujoco.mj_forward(sim.model, sim.data)
    np.testing.assert_allclose(weak.data.actuator_force, 0.8 * plain.data.actuator_force)


def test_a_run_records_its_mismatch_and_the_robust_g1_walks_10_percent_heavier():
    from robust_ismpc.control.modules import controller_modules
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.runs.run import run

    mismatch = ModelMismatch(mass_scale=1.1)
    result = run(RunSpec(robot="g1", sim="mujoco", modules=controller_modules("robust"), command=WalkCommand(0.2),
                         duration_s=8.0, mismatch=mismatch))
    assert result.summary["mismatch"] == mismatch.as_dict()
    assert not result.summary["fell"], result.summary["failure"]
    assert result.summary["distance_m"] > 0.6 * 0.2 * (8.0 - 2.6)


def _path_deviations_with_a_payload(offset_m: tuple[float, float, float], duration_s: float) -> dict[str, float]:
    """G1 at 0.2 m/s with a 10 % payload (3.3 kg) at ``offset_m`` from its torso: the
    stride-averaged path deviation [m] of the nominal and the robust controller, each walking."""
    from robust_ismpc.control.modules import controller_modules
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.experiments.scenarios.compare import path_deviation
    from robust_ismpc.runs.run import run

    command = WalkCommand(0.2)
    deviation = {}
    for name in ("nominal", "robust"):
        result = run(RunSpec(robot="g1", sim="mujoco", modules=controller_modules(name), command=command,
                             duration_s=duration_s, mismatch=ModelMismatch(payload_kg=3.3, payload_offset_m=offset_m)))
        assert not result.summary["fell"], result.summary["failure"]
        deviation[name] = path_deviation(result.trace, command)["max_m"]
    return deviation


@pytest.mark.slow
def test_a_payload_over_the_com_does_not_lead_the_robust_g1_off_its_path():
    """A 10 % payload over the CoM, 20 s at 0.2 m/s: the robust G1 keeps its path as well as the
    nominal one (within 1 cm). Divided by the model's mass, the contact force read the gait's own
    acceleration as a disturbance and the robust G1 ended 17.7 cm off its line (nominal 4.9 cm;
    both with the stride average from t = 0); with the inverse dynamics unaware of the payload's
    weight, the robot walked 5 % slow and the robust G1 ended 3.0 cm off (nominal 1.3 cm)."""
    deviation = _path_deviations_with_a_payload((0.05, 0.0, 0.0), 20.0)
    assert deviation["robust"] <= deviation["nominal"] + 0.01, deviation


def test_a_payload_off_centre_is_a_moment_and_the_robust_g1_keeps_its_path():
    """A 10 % payload 5 cm left of the torso (and 5 cm behind the CoM), 12 s at 0.2 m/s: its
    weight is a moment about the CoM, which the robust G1 measures as such and its whole body
    takes as a moment, so it keeps its path (under the 3 cm of issue 28) as well as the nominal
    one (within 1.5 cm). Taken as a force on the torso, the whole body pushed the robot off its
    line (10.8 cm in 12 s, 31.9 cm in 20 s; with the force as a uniform field on every link 7.3 cm
    in 20 s, nominal 4.8; all measured with the stride average from t = 0, which counted the
    first weight shift as 4.8 cm)."""
    deviation = _path_deviations_with_a_payload((0.0, 0.05, 0.0), 12.0)
    assert deviation["robust"] <= deviation["nominal"] + 0.015, deviation
    assert deviation["robust"] < 0.03, deviation


def test_the_cli_names_the_flag_of_a_bad_mismatch(tmp_path, capsys):
    from robust_ismpc.cli import main

    assert main(["run", "--mismatch", "mass=1.1", "--duration", "1", "--out", str(tmp_path / "a"), "--quiet"]) == 2
    assert "needs --sim mujoco" in capsys.readouterr().err
    assert main(["run", "--sim", "mujoco", "--mismatch", "weight=2", "--duration", "1",
                 "--out", str(tmp_path / "b"), "--quiet"]) == 2
    assert "--mismatch 'weight=2'" in capsys.readouterr().err
