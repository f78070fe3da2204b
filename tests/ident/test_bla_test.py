"""The nonparametric BLA's test of linear orders (porosense.ident.bla_test).

Own generator: random-phase multisines (a random band, random amplitude), through a random
stable linear system of known order with a random static nonlinearity in front (a Wiener
system, whose BLA is the linear block up to a gain) plus output noise; each realisation two
periods.
"""

import numpy as np
import pytest
from scipy.signal import lfilter

from porosense import ident
from porosense.ident.bla_test import NonparametricBLA

PERIOD = 1024


def _system(rng):
    r, a = rng.uniform(0.5, 0.85), rng.uniform(0.3, 1.2)
    den = np.real(np.poly([r * np.exp(1j * a), r * np.exp(-1j * a)]))
    num = np.array([1.0, rng.uniform(-0.6, 0.6)])
    return num * den.sum() / num.sum(), den, rng.uniform(0.3, 1.5)


def _records(rng, system, m, noise=0.05):
    b, den, bend = system
    top = int(rng.integers(PERIOD // 8, PERIOD // 3))
    us, ys = [], []
    for _ in range(m):
        spec = np.zeros(PERIOD // 2 + 1, complex)
        spec[1:top] = np.exp(2j * np.pi * rng.random(top - 1))
        u = np.fft.irfft(spec, PERIOD)
        u = np.tile(u / np.std(u), 2)
        x = np.tanh(bend * u) / bend  # a static nonlinearity: the BLA is the filter times a gain
        y = lfilter(b, den, x) + noise * rng.standard_normal(len(u))
        us.append(u[:, None])
        ys.append(y)
    return us, ys


class _Exact:
    """The generator's own linear block scaled by the BLA gain, as a model (predict only)."""

    def __init__(self, b, den, gain):
        self.b, self.den, self.gain = b, den, gain

    def predict(self, *, u):
        return self.gain * lfilter(self.b, self.den, np.asarray(u)[:, 0])


def test_a_right_linear_model_is_refuted_at_about_the_stated_level():
    """At alpha = 5 %, the generator's exact BLA (its filter times the Gaussian-input gain,
    estimated once from a long record) is refuted in about 5 % of 60 independent experiments
    (6 realisations each). Measured: 4 of 60. Bound: at most 9 (the 99 % binomial quantile of
    60 draws at 5 % is 8; one more for the gain estimate)."""
    rng = np.random.default_rng(3)
    refuted = 0
    for _ in range(60):
        system = _system(rng)
        b, den, bend = system
        long = rng.standard_normal(200_000)
        gain = float(np.dot(np.tanh(bend * long) / bend, long) / np.dot(long, long))
        us, ys = _records(rng, system, 6)
        bla = NonparametricBLA.from_records(us, ys)
        refuted += bla.misfit(_Exact(b, den, gain), us) > bla.threshold(0.05)
    print(f"exact BLA refuted in {refuted} of 60 experiments at 5 %")
    assert refuted <= 9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fitted_orders_below_the_truth_are_refuted_and_the_truth_is_not(seed):
    """Linear OE fits of 1..4 poles on 6 realisations of a 2-pole system: the 1-pole fit is
    refuted at 1 %, the 2-pole 1-zero fit is not, and the fewest-parameter order the test keeps
    has at most 3 poles."""
    rng = np.random.default_rng(100 + seed)
    system = _system(rng)
    us, ys = _records(rng, system, 6)
    bla = NonparametricBLA.from_records(us, ys)
    limit = bla.threshold(0.01)
    misfit = {}
    for p, z in [(1, 0), (2, 0), (2, 1), (3, 1), (3, 2), (4, 2)]:
        m = ident.Linear(n_poles=p, n_zeros=z, max_nfev=100).fit(u=us, y=ys, ts=1.0)
        misfit[(p, z)] = bla.misfit(m, us)
    print(f"seed {seed}: limit {limit:.3f}, " + ", ".join(f"{p}p{z}z {v:.2f}" for (p, z), v in misfit.items()))
    assert misfit[(1, 0)] > limit and misfit[(2, 1)] <= limit
    kept = [o for o, v in misfit.items() if v <= limit]
    assert min(kept, key=lambda o: (o[0] + o[1], o))[0] <= 3


def test_no_bla_without_enough_realisations_or_repeats():
    rng = np.random.default_rng(7)
    us, ys = _records(rng, _system(rng), 3)
    assert NonparametricBLA.from_records(us, ys) is None  # 3 realisations: F(2, 4) has no variance
    us, ys = _records(rng, _system(rng), 5)
    assert NonparametricBLA.from_records(us, ys) is not None
    noisy = [u + 0.5 * rng.standard_normal(u.shape) for u in us]  # no longer periodic
    assert NonparametricBLA.from_records(noisy, ys) is None


def test_identify_help_states_the_levels_the_code_uses():
    """--help names the levels as numbers (the CLI does not import the engine to print help)."""
    import argparse
    import importlib

    from porosense.ident import noise_level

    search = importlib.import_module("porosense.ident.search")  # the module, not the function
    parser = argparse.ArgumentParser()
    importlib.import_module("porosense.cli.identify").register(parser.add_subparsers())
    text = parser._subparsers._group_actions[0].choices["identify"].format_help()
    text = " ".join(text.split())
    assert f"beyond {noise_level.CONSISTENCY_Z:.2f} standard errors, 1 % two-sided" in text
    assert f"not refuted at {100 * search.BLA_ALPHA:g} %" in text
