"""Regularisation of the static nonlinearity: smoothness penalty and monotone constraint.

Truth: a Wiener system whose g is a saturating curve drawn here (tanh with random gain and
offset), strong output noise so that an unregularised 16-breakpoint map wiggles.
"""

import numpy as np
import pytest
from scipy import signal

from porosense import ident
from porosense.ident.blocks import pwl_positions


@pytest.fixture(scope="module")
def noisy_wiener():
    rng = np.random.default_rng(3)
    gain, shift = rng.uniform(1.5, 3.0), rng.uniform(-0.3, 0.3)
    us, ys = [], []
    for _ in range(2):
        u = np.repeat(rng.uniform(-1, 1, 40), 15)
        s = signal.lfilter([0.2], [1.0, -0.8], u)
        y = np.tanh(gain * (s - shift))
        us.append(u[:, None])
        ys.append(y + 0.4 * np.std(y) * rng.standard_normal(len(y)))
    return us, ys


def _g_values(model):
    sl = model.spec.slices()
    return np.asarray(model.theta[sl["g.y"]])


ORD = dict(n_poles=1, n_zeros=0, n_breakpoints=16, max_nfev=80)


def test_monotone_maps_come_out_monotone(noisy_wiener):
    us, ys = noisy_wiener
    free = ident.Wiener(**ORD).fit(u=us, y=ys, ts=1.0)
    mono = ident.Wiener(monotone=True, **ORD).fit(u=us, y=ys, ts=1.0)
    steps_free, steps_mono = np.diff(_g_values(free)), np.diff(_g_values(mono))
    span = np.ptp(_g_values(mono))
    sign = np.sign(_g_values(mono)[-1] - _g_values(mono)[0])
    print("free steps against the trend:", int(np.sum(steps_free * sign < 0)), "monotone:", steps_mono * sign)
    # A stiff penalty, not a hard bound: violations are below 1 % of the map's span.
    assert np.all(steps_mono * sign >= -0.01 * span)


def test_smoothness_weight_reduces_the_bending_of_the_map(noisy_wiener):
    us, ys = noisy_wiener
    bend = {}
    for w in (0.0, 1e-2):
        m = ident.Wiener(smoothness=w, **ORD).fit(u=us, y=ys, ts=1.0)
        bend[w] = float(np.sum(np.diff(_g_values(m), 2) ** 2))
        assert np.all(np.diff(pwl_positions(m.theta[m.spec.slices()["g.p"]])[0]) > 0)
    print("sum of squared second differences:", bend)
    assert bend[1e-2] < 0.5 * bend[0.0]


def test_smoothness_weight_is_chosen_on_validation(noisy_wiener):
    us, ys = noisy_wiener
    res = ident.search(
        u=us[:1],
        y=ys[:1],
        ts=1.0,
        validation=(us[1:], ys[1:]),
        structures=("wiener",),
        poles=[1],
        zeros=[0],
        n_breakpoints=16,
        max_nfev=60,
        criterion="fit",
        progress=False,
    )
    choice = ident.choose_smoothness(res, u=us[:1], y=ys[:1], ts=1.0, validation=(us[1:], ys[1:]))
    print(choice)
    assert set(choice.fits) == {0.0, 1e-4, 1e-3, 1e-2}
    assert choice.fits[choice.weight] == max(choice.fits.values())
    assert choice.model.smoothness == choice.weight
