"""Tests of the extended LIP model (spec §2)."""

import numpy as np
import pytest
from scipy.linalg import expm

from robust_ismpc.core.lip import continuous_matrices, dcm, discretise, step_state
from robust_ismpc.exceptions import ParameterError


@pytest.mark.parametrize("eta,dt", [(3.5, 0.01), (6.5, 0.05), (2.4, 0.1)])
def test_exact_discretisation_equals_matrix_exponential(eta, dt):
    """A_d, B_d and E_d equal the blocks of expm of the augmented continuous system."""
    A, B, E = continuous_matrices(eta)
    M = np.zeros((5, 5))
    M[:3, :3] = A
    M[:3, 3] = B
    M[:3, 4] = E
    Md = expm(M * dt)
    disc = discretise(eta, dt)
    np.testing.assert_allclose(disc.A, Md[:3, :3], atol=1e-12)
    np.testing.assert_allclose(disc.B, Md[:3, 3], atol=1e-12)
    np.testing.assert_allclose(disc.E, Md[:3, 4], atol=1e-12)


def test_ramp_zmp_from_rest_matches_closed_form():
    """A ZMP ramp x_z = u t from rest gives x_c(δ) = u (δ - sinh(ηδ)/η) (spec §2.2 check)."""
    eta, dt, u = 3.7, 0.01, 0.4
    x = step_state(discretise(eta, dt), np.zeros(3), u)
    assert x[0] == pytest.approx(u * (dt - np.sinh(eta * dt) / eta), abs=1e-15)
    assert x[2] == pytest.approx(u * dt)


def test_dcm_obeys_its_dynamics():
    """Along a trajectory, the DCM satisfies ẋ_u = η(x_u - x_z) + w/η (finite differences)."""
    eta, dt, w = 4.0, 1e-4, 0.3
    disc = discretise(eta, dt)
    state = np.array([0.01, 0.05, -0.02])
    for _ in range(100):
        u = 0.2
        nxt = step_state(disc, state, u, w)
        xu0 = dcm(state[0], state[1], eta)
        xu1 = dcm(nxt[0], nxt[1], eta)
        mid_zmp = 0.5 * (state[2] + nxt[2])
        mid_xu = 0.5 * (xu0 + xu1)
        assert (xu1 - xu0) / dt == pytest.approx(eta * (mid_xu - mid_zmp) + w / eta, rel=1e-6)
        state = nxt


def test_shifted_dcm_follows_nominal_law_under_constant_disturbance():
    """x̄_u = x_u + w/η² obeys dx̄_u/dt = η(x̄_u - x_z) for constant w (spec §2.1)."""
    eta, dt, w = 3.0, 1e-4, 0.8
    disc = discretise(eta, dt)
    state = np.array([0.0, 0.1, 0.0])
    nxt = step_state(disc, state, 0.0, w)
    bar0 = dcm(state[0], state[1], eta) + w / eta**2
    bar1 = dcm(nxt[0], nxt[1], eta) + w / eta**2
    assert (bar1 - bar0) / dt == pytest.approx(eta * (0.5 * (bar0 + bar1) - state[2]), rel=1e-6)


def test_discretise_rejects_bad_values():
    """Non-positive or non-finite η or period raise ParameterError."""
    for eta, dt in [(0.0, 0.01), (3.0, -0.01), (float("nan"), 0.01)]:
        with pytest.raises(ParameterError):
            discretise(eta, dt)
