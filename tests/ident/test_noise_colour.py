"""The colour of the period differences against a model's noise path (noise_colour).

The records come from a generator written here, independent of the identification code: a WH
system with random stable H1 (1-2 poles, a zero) and H2 (1-3 poles, a zero), unit DC gains, a
monotone piecewise-linear g with 3 kinks at random places and slopes over a factor 20, white
Gaussian process noise at g's input (0.2-0.6 of its spread), white measurement noise at the
output (0-2 % of its spread), and random-noise inputs repeated twice. The true system is then
written in the model's parameters, once as it is and once with every pole and zero moved into H1
(the same product H1 H2, so the same best linear approximation, but the noise through g alone).
"""

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import binom

from porosense.ident import blocks, noise_colour, noise_level
from porosense.ident.chain import ChainSpec

SKIP = 50


def _stable(rng, n_poles):
    poles = []
    while len(poles) < n_poles:
        if n_poles - len(poles) >= 2 and rng.random() < 0.5:
            r, a = rng.uniform(0.5, 0.95), rng.uniform(0.05, 1.5)
            poles += [r * np.exp(1j * a), r * np.exp(-1j * a)]
        else:
            poles.append(rng.uniform(0.2, 0.95))
    den = np.real(np.poly(poles))
    num = np.array([1.0, rng.uniform(-0.6, 0.6)])
    return num * np.sum(den) / np.sum(num), den


def _world(seed, period, records=4, all_in_h1=False):
    """(spec, theta, inputs, outputs): records of one random system and the system as a model."""
    rng = np.random.default_rng(seed)
    (b1, a1), (b2, a2) = _stable(rng, int(rng.integers(1, 3))), _stable(rng, int(rng.integers(1, 4)))
    b1 = b1 / np.std(lfilter(b1, a1, rng.standard_normal(20000)))  # g's input at unit spread
    xs = np.r_[-6.0, np.sort(rng.uniform(-1.5, 1.5, 3)), 6.0]
    gy = np.cumsum(np.r_[0.0, np.diff(xs) * rng.uniform(0.1, 2.0, len(xs) - 1)])
    sigma, out_noise = rng.uniform(0.2, 0.6), rng.uniform(0.0, 0.02)
    us, ys = [], []
    for _ in range(records):
        u = np.tile(rng.standard_normal(period), 2)
        x = lfilter(b1, a1, u) + sigma * rng.standard_normal(len(u))
        y = lfilter(b2, a2, np.interp(x, xs, gy))
        us.append(u[:, None])
        ys.append(y + out_noise * np.std(y) * rng.standard_normal(len(y)))
    if all_in_h1:
        b1, a1, b2, a2 = np.convolve(b1, b2), np.convolve(a1, a2), np.ones(1), np.ones(1)
    np1, np2 = len(a1) - 1, len(a2) - 1
    spec = ChainSpec(1, np1, len(b1) - 1, g_bp=len(xs), h2=np2 > 0, np2=np2, nz2=len(b2) - 1, g_noise=True)
    sl = spec.slices()
    theta = np.zeros(spec.n_params)
    theta[sl["h10.a"]], theta[sl["h10.b"]] = blocks.theta_from_poly(a1, np1), b1
    theta[sl["g.p"]], theta[sl["g.y"]], theta[sl["g.s"]] = blocks.positions_to_p(xs), gy, np.log(sigma)
    if np2:
        theta[sl["h2.a"]], theta[sl["h2.b"]] = blocks.theta_from_poly(a2, np2), b2
    return spec, theta, us, ys


def _p_values(period, all_in_h1, seeds):
    out = []
    for seed in seeds:
        spec, theta, us, ys = _world(seed, period, all_in_h1=all_in_h1)
        out.append(noise_colour.check(noise_level.PeriodData(us, ys, SKIP), spec, theta, us).p_value)
    return np.array(out)


@pytest.mark.parametrize("period", [800, 3000])
def test_the_true_noise_path_is_refuted_at_about_its_level(period):
    """The true system is refuted at 1 % in about 1 % of the data sets. Measured over 60 seeds:
    3 with 800-sample periods (4 records, about 40 Welch segments for 11 bands: the band
    variances are themselves uncertain; median p 0.31), 1 with 3000 (median p 0.62). Bound: the
    binomial 99.9 % quantile of 60 draws at 1 % plus 2 (6), a level of at most about 10 %."""
    p = _p_values(period, False, range(60))
    rejected = int(np.sum(p < noise_colour.ALPHA))
    bound = int(binom.ppf(0.999, 60, noise_colour.ALPHA)) + 2
    print(f"period {period}: true noise path refuted in {rejected} of 60 (bound {bound}); median p {np.median(p):.2f}")
    assert rejected <= bound


def test_the_noise_path_through_the_wrong_block_is_refuted():
    """The same system with H2 moved into H1 (noise through g alone, the same BLA) is refuted at
    1 %: measured 60 of 60 (1500-sample periods; 39 of 40 with 800, 40 of 40 with 3000).
    Bound: 54 of 60."""
    p = _p_values(1500, True, range(60))
    refuted = int(np.sum(p < noise_colour.ALPHA))
    print(f"noise through the wrong block refuted in {refuted} of 60")
    assert refuted >= 54


def test_a_model_without_process_noise_is_an_error():
    spec, theta, us, ys = _world(0, 800)
    plain = ChainSpec(1, spec.np1, spec.nz1, g_bp=spec.g_bp, h2=spec.h2, np2=spec.np2, nz2=spec.nz2)
    keep = [k for k in range(spec.n_params) if k != spec.slices()["g.s"].start]
    with pytest.raises(ValueError, match="no process noise"):
        noise_colour.check(noise_level.PeriodData(us, ys, SKIP), plain, theta[keep], us)
