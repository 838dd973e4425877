"""Swing-foot trajectories: land on target at touchdown, apex at mid-swing, continuous when re-timed."""

import numpy as np
import pytest
from fixtures import walking_controller

from robust_ismpc.core.swing import SwingState, advance_swing, quintic_step

DT = 0.01


def _fly(T_ss, target, height=0.05, retime=None):
    state = SwingState.at_rest(np.zeros(2), 0.0)
    touchdown = T_ss
    states = []
    t = 0.0
    while t < touchdown - 1e-9:
        if retime is not None and abs(t - retime[0]) < 1e-9:
            touchdown = retime[1]
        state = advance_swing(state, target, 0.3, touchdown - t, DT, height)
        states.append(state)
        t += DT
    return states


def test_lands_on_target_at_touchdown_with_zero_velocity():
    """At touchdown the foot is on the target (z = 0, yaw reached) with zero horizontal velocity."""
    end = _fly(0.5, np.array([0.2, 0.1]))[-1]
    np.testing.assert_allclose(end.pos_m, [0.2, 0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(end.vel_mps[:2], 0.0, atol=1e-12)
    assert end.yaw_rad == pytest.approx(0.3)


def test_apex_height_at_mid_swing():
    """The height profile peaks at the apex height at mid-swing."""
    states = _fly(0.5, np.array([0.2, 0.0]), height=0.05)
    z = np.array([s.pos_m[2] for s in states])
    assert z.max() == pytest.approx(0.05, abs=2e-3)
    assert abs(int(np.argmax(z)) - len(z) / 2) <= 2


def test_replanned_quintic_equals_single_quintic():
    """Re-planning every tick from the current state reproduces one rest-to-rest quintic."""
    states = _fly(0.5, np.array([0.2, 0.0]))
    x = np.array([s.pos_m[0] for s in states])
    tau = np.arange(1, len(x) + 1) * DT / 0.5
    np.testing.assert_allclose(x, 0.2 * (10 * tau**3 - 15 * tau**4 + 6 * tau**5), atol=1e-12)


def test_retiming_mid_swing_is_continuous_and_lands_at_new_time():
    """Shortening the swing mid-way keeps position continuous and lands at the new touchdown."""
    states = _fly(0.5, np.array([0.2, 0.0]), retime=(0.2, 0.35))
    assert len(states) == 35
    pos = np.array([s.pos_m for s in states])
    assert np.max(np.abs(np.diff(pos, axis=0))) < 0.03  # no jump larger than a normal tick's motion
    np.testing.assert_allclose(pos[-1], [0.2, 0.0, 0.0], atol=1e-12)


def test_quintic_boundary_conditions():
    """quintic_step honours the end state and returns it past the end."""
    p, v, a = quintic_step(np.array([0.0]), np.array([1.0]), np.array([0.0]), np.array([1.0]), 0.5, 0.5)
    assert p[0] == 1.0 and v[0] == 0.0 and a[0] == 0.0


def test_rounded_touchdown_still_lands_and_next_swing_lifts():
    """A touchdown a hair after the last tick still lands exactly (progress 1)."""
    state = SwingState.at_rest(np.zeros(2), 0.0)
    state = advance_swing(state, np.array([0.1, 0.0]), 0.0, DT + 1e-13, DT, 0.05)
    assert state.progress == 1.0 and state.pos_m[2] == 0.0


def test_every_swing_of_a_long_walk_lifts_the_foot():
    """In a 30 s walk every single support lifts the swing foot to about the swing height."""
    controller = walking_controller("g1", 0.2, duration_s=30.0)
    plan = controller.plan
    peaks: dict[int, float] = {}
    for k in range(3000):
        ref = controller.step(k * 0.01)
        j = ref.step_index
        if j >= 2:
            z = max(ref.left_foot.pos_m[2], ref.right_foot.pos_m[2])
            peaks[j] = max(peaks.get(j, 0.0), z)
    done = [j for j in peaks if plan.touchdown_s[j] < 29.0]
    assert len(done) > 35
    assert min(peaks[j] for j in done) > 0.9 * controller.robot.swing_height_m
