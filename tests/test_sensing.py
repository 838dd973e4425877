"""The sensor model between a simulator's true state and the controller (robots/sensing.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from robust_ismpc.control.walk import make_controller, start_walk
from robust_ismpc.core.params import robot_params
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.core.reference import Measurement
from robust_ismpc.estimation.estimator import EstimatorParams
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.robots.sensing import SENSING_PRESETS, SensingParams, Sensors, sensing_preset
from robust_ismpc.runs.lip import run_lip
from robust_ismpc.runs.spec import RunSpec

DT = 0.01
ETA = 4.0


def _truth(k: int) -> Measurement:
    return Measurement(com_pos_m=np.array([0.01 * k, -0.002 * k, 0.7]), com_vel_mps=np.array([0.1, 0.2, 0.0]),
                       zmp_m=np.array([0.0, 0.01 * k]), left_sole_m=np.array([0.0, 0.1]),
                       right_sole_m=np.array([0.0, -0.1]), contact_acc_mps2=np.array([0.3, -0.1]),
                       external_moment_acc_mps2=np.array([0.05, 0.0]))


def test_ideal_sensors_return_the_truth():
    sensors = Sensors(sensing_preset("ideal"), DT, ETA)
    truth = _truth(3)
    assert sensors.read(truth) is truth


def test_the_noise_has_the_standard_deviations_of_the_model():
    """Over 4000 ticks each noise's sample standard deviation is within 5 % of the model's."""
    params = SENSING_PRESETS["realistic"]
    sensors = Sensors(replace(params, latency_s=0.0), DT, ETA, seed=4)
    truth = _truth(0)
    reads = [sensors.read(truth) for _ in range(4000)]
    vel = np.array([r.com_vel_mps[:2] for r in reads]) - truth.com_vel_mps[:2]
    acc = np.array([r.contact_acc_mps2 for r in reads]) - truth.contact_acc_mps2
    pos = np.array([r.com_pos_m[:2] for r in reads]) - truth.com_pos_m[:2] - sensors.com_bias_m
    np.testing.assert_allclose(vel.std(axis=0), params.com_vel_noise_mps, rtol=0.05)
    np.testing.assert_allclose(acc.std(axis=0), params.contact_force_noise * 9.81, rtol=0.05)
    np.testing.assert_allclose(pos.std(axis=0), params.com_pos_noise_m, rtol=0.05)
    np.testing.assert_allclose(pos.mean(axis=0), 0.0, atol=3 * params.com_pos_noise_m / np.sqrt(4000))


def test_latency_delivers_the_reading_of_that_many_periods_ago():
    sensors = Sensors(SensingParams(name="late", latency_s=0.03), DT, ETA)
    reads = [sensors.read(_truth(k)) for k in range(10)]
    for k in range(3, 10):
        np.testing.assert_array_equal(reads[k].com_pos_m, _truth(k - 3).com_pos_m)
    np.testing.assert_array_equal(reads[1].com_pos_m, _truth(0).com_pos_m)  # until then: the first


def test_the_com_bias_shows_in_the_external_moment_as_minus_eta_squared_b():
    """The weight at the true CoM has a moment -b x m g about the measured one: as an LIP
    acceleration, -η² b."""
    sensors = Sensors(SensingParams(name="biased", com_pos_bias_m=0.01), DT, ETA, seed=7)
    truth = _truth(0)
    read = sensors.read(truth)
    b = read.com_pos_m[:2] - truth.com_pos_m[:2]
    assert np.hypot(*b) == pytest.approx(0.01)
    np.testing.assert_allclose(read.external_moment_acc_mps2 - truth.external_moment_acc_mps2, -ETA**2 * b)
    np.testing.assert_array_equal(read.com_vel_mps, truth.com_vel_mps)


def test_the_estimator_takes_the_larger_noise_of_model_and_sensors():
    base = EstimatorParams(com_pos_noise_m=0.005, com_vel_noise_mps=0.01, acc_noise_mps2=0.5)
    est = SENSING_PRESETS["realistic"].estimator_params(base)
    assert est.com_pos_noise_m == 0.005 and est.com_vel_noise_mps == 0.03
    assert est.sensor_vel_noise_mps == 0.03
    assert SENSING_PRESETS["ideal"].estimator_params(base) is base


@pytest.mark.parametrize("kwargs, match", [
    ({"com_vel_noise_mps": -0.1}, "com_vel_noise_mps"),
    ({"latency_s": float("nan")}, "latency_s"),
    ({"name": ""}, "name"),
])
def test_bad_sensing_params_raise(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        SensingParams(**kwargs)


def test_a_latency_that_is_not_whole_periods_and_an_unknown_preset_raise():
    with pytest.raises(ParameterError, match="whole number"):
        Sensors(SensingParams(name="x", latency_s=0.015), DT, ETA)
    with pytest.raises(ParameterError, match="ideal, realistic"):
        sensing_preset("perfect")
    with pytest.raises(ParameterError, match="unknown sensing"):
        RunSpec(sensing="perfect")


def _walk(modules, sensing: SensingParams, seconds: float, seed: int):
    robot = robot_params("g1")
    controller = make_controller(robot, None, modules, estimator=sensing.estimator_params(EstimatorParams()))
    start_walk(controller, WalkCommand(0.2, 0.0, 0.0), seconds)
    outcome, recorder = run_lip(controller, seconds, sensors=Sensors(sensing, controller.dt, robot.eta, seed))
    return outcome, recorder.finish(controller.plan, {})


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_robust_controller_reads_a_com_bias_as_a_disturbance_and_walks(seed):
    """A 1 cm CoM bias (the mass model's error) is a persistent disturbance -η² b for the LIP the
    MPC plans with: the robust controller's estimate settles there and it walks 10 s."""
    sensing = SensingParams(name="biased", com_pos_bias_m=0.01)
    outcome, trace = _walk(("observer", "restriction", "timing"), sensing, 10.0, seed)
    assert not outcome.fell, outcome.failure
    bias = Sensors(sensing, DT, robot_params("g1").eta, seed).com_bias_m
    w = trace.channels["disturbance_measured_mps2"][500:]
    np.testing.assert_allclose(w.mean(axis=0), -robot_params("g1").eta ** 2 * bias, atol=0.03)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_under_sensor_noise_the_robust_controller_walks_with_a_quiet_estimate(seed):
    """Velocity noise of 3 cm/s and contact-force noise of 2 % of the weight: the robust controller
    walks 10 s undisturbed, and its estimate's noise stays below 0.1 m/s² (3.3 N on G1)."""
    sensing = SensingParams(name="noisy", com_vel_noise_mps=0.03, contact_force_noise=0.02)
    outcome, trace = _walk(("observer", "restriction", "timing"), sensing, 10.0, seed)
    assert not outcome.fell, outcome.failure
    w = trace.channels["disturbance_measured_mps2"][100:]
    assert np.all(w.std(axis=0) < 0.1)


def test_a_run_names_its_sensing_in_its_summary():
    from robust_ismpc.runs.run import run

    result = run(RunSpec(robot="g1", sim="lip", duration_s=2.0, sensing="realistic", seed=3))
    assert result.summary["sensing"] == SENSING_PRESETS["realistic"].as_dict()
    assert result.summary["seed"] == 3
    # the velocity the controller read errs by the preset's 3 cm/s noise (and 10 ms of latency)
    error = result.summary["com_vel_read_error_rms_mps"]
    assert all(0.025 < e < 0.04 for e in error), error
    # the CoM it read is off by the preset's 1 cm bias (mean) and 2 mm of noise (spread)
    bias = result.summary["com_read_error_mean_m"]
    assert 0.008 < math.hypot(*bias) < 0.012, bias
    assert all(0.0015 < e < 0.003 for e in result.summary["com_read_error_std_m"])
    ideal = run(RunSpec(robot="g1", sim="lip", duration_s=0.5)).summary
    assert "com_vel_read_error_rms_mps" not in ideal and "com_read_error_mean_m" not in ideal


def test_soak_and_sweep_pass_their_sensing_to_every_run():
    from robust_ismpc.experiments.soak import SoakSpec, run_soak
    from robust_ismpc.experiments.sweep.bisection import Bisection
    from robust_ismpc.experiments.sweep.config import SweepConfig
    from robust_ismpc.experiments.sweep.run import _make_trial
    from robust_ismpc.experiments.sweep.trials import TaskKey

    report, result = run_soak(SoakSpec(duration_s=2.0, sensing="realistic"))
    assert report["sensing"] == "realistic"
    assert result.summary["sensing"] == SENSING_PRESETS["realistic"].as_dict()
    config = SweepConfig(sensing="realistic")
    assert config.to_dict()["sensing"] == "realistic"
    trial = _make_trial(config, TaskKey("robust", 0.0, 0.0, "impulse"), Bisection(10.0, 4), (3.0, 0.5))
    assert trial.sensing == "realistic"
    with pytest.raises(ParameterError, match="unknown sensing"):
        SweepConfig(sensing="perfect")
