"""The Laguerre bank and the play operator against properties that hold by construction of the
mathematics, not of the code: orthonormal Laguerre impulse responses, steady states, and the
play operator's bounded lag."""

import numpy as np
import pytest

from porosense.dsp import laguerre_bank, play_operator


@pytest.mark.parametrize("pole", [0.0, 0.5, 0.9])
def test_laguerre_impulse_responses_are_orthonormal(pole):
    n = 4000 if pole < 0.95 else 20000
    x = np.zeros(n)
    x[0] = 1.0
    h = laguerre_bank(x, pole, 5)
    gram = h.T @ h
    # The tail beyond n samples holds pole^(2n) of the energy: nothing at these sizes.
    assert np.max(np.abs(gram - np.eye(5))) < 1e-9


def test_settled_bank_holds_a_constant_input_still():
    x = np.full(300, 2.5)
    a = 0.8
    out = laguerre_bank(x, a, 4, settled=True)
    steady = 2.5 * np.sqrt(1.0 - a * a) / (1.0 - a)
    assert np.max(np.abs(out - steady)) < 1e-12
    # From rest the same input rises towards that steady state instead.
    rest = laguerre_bank(x, a, 4)
    assert abs(rest[0, 0] - 2.5 * np.sqrt(1.0 - a * a)) < 1e-12
    assert np.max(np.abs(rest[-1] - steady)) < 1e-9


def test_settled_bank_is_the_bank_of_the_deviation_plus_its_steady_state():
    rng = np.random.default_rng(4)
    x = 3.0 + np.cumsum(rng.normal(0, 0.1, 500))
    a = 0.7
    got = laguerre_bank(x, a, 3, settled=True)
    want = laguerre_bank(x - x[0], a, 3) + x[0] * np.sqrt(1 - a * a) / (1 - a)
    assert np.max(np.abs(got - want)) < 1e-12


def test_play_operator_lags_by_its_radius_and_stays_within_it():
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.normal(0, 1.0, 2000))
    r = 1.5
    z = play_operator(x, r)
    assert np.max(np.abs(z - x)) <= r + 1e-12
    assert z[0] == x[0]
    # Between reversals the output moves only when the input pushes the play's edge.
    moved = np.flatnonzero(np.diff(z) != 0) + 1
    assert np.allclose(np.abs(x[moved] - z[moved]), r)


def test_play_operator_on_a_triangle_traces_the_textbook_loop():
    up = np.linspace(0.0, 4.0, 9)
    x = np.concatenate([up, up[::-1][1:]])
    z = play_operator(x, 1.0)
    # Rising from 0: held at 0 until x passes 1, then x - 1; falling: held at 3 until x < 2.
    assert np.allclose(z[:9], np.maximum(0.0, up - 1.0))
    assert np.allclose(z[9:], np.minimum(3.0, up[::-1][1:] + 1.0))
    assert play_operator(np.array([]), 1.0).shape == (0,)
