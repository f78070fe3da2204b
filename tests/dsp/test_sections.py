"""Pure delays folded into second-order sections: the cascade's impulse response must be the
transfer function's, computed independently by scipy's direct-form filter (lfilter)."""

import numpy as np
import pytest
from scipy import signal

from porosense.dsp import fold_delay, split_delay

N = 64


def _impulse(sos) -> np.ndarray:
    x = np.zeros(N)
    x[0] = 1.0
    return signal.sosfilt(sos, x)


@pytest.mark.parametrize("delay", [0, 1, 2, 3, 5])
@pytest.mark.parametrize("n_zeros", [0, 1, 2, 3])
def test_folded_cascade_has_the_delayed_impulse_response(delay, n_zeros):
    rng = np.random.default_rng(10 * delay + n_zeros)
    poles = rng.uniform(0.2, 0.9, 4) * np.exp(1j * rng.uniform(0, np.pi, 4))
    poles = np.concatenate([poles[:2], np.conj(poles[:2])])
    zeros = rng.uniform(-0.8, 0.8, n_zeros)
    b, a = np.atleast_1d(np.poly(zeros)) * rng.uniform(0.5, 2.0), np.real(np.poly(poles))
    sos = signal.zpk2sos(np.concatenate([zeros, np.zeros(4 - n_zeros)]), poles, b[0])
    folded = fold_delay(sos, delay)
    x = np.zeros(N)
    x[0] = 1.0
    want = signal.lfilter(np.concatenate([np.zeros(delay), b]), a, x)
    got = _impulse(folded)
    err = np.max(np.abs(got - want)) / np.max(np.abs(want))
    assert err < 1e-9, err
    # Sections are added only when the numerators' trailing zeros are used up; each added z^-1
    # section takes two samples of delay.
    room = sum(3 - len(np.trim_zeros(row[:3], "b")) for row in sos)
    assert len(folded) == len(sos) + -(-max(0, delay - room) // 2)


def test_fold_delay_leaves_its_input_alone():
    sos = np.array([[1.0, 0.5, 0.0, 1.0, -0.5, 0.0]])
    before = sos.copy()
    out = fold_delay(sos, 2)
    assert np.array_equal(sos, before)
    assert out.shape == (2, 6)


def test_split_delay_counts_leading_zeros():
    delay, rest = split_delay([0.0, 0.0, 2.0, 0.0, 1.0])
    assert delay == 2 and list(rest) == [2.0, 0.0, 1.0]
    assert split_delay([3.0])[0] == 0
