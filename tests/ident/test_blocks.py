"""Parametrised blocks: stability by construction and exact Jacobians."""

import numpy as np
import pytest

from porosense.ident import blocks
from porosense.ident.chain import Chain, ChainSpec


def test_every_parameter_vector_gives_stable_sections():
    rng = np.random.default_rng(0)
    margin = np.inf
    for n in range(1, 11):
        for _ in range(50):
            den, _ = blocks.sections(rng.normal(scale=30.0, size=n))
            # Jury's test of 1 + a1 z^-1 + a2 z^-2: |a2| < 1 and |a1| < 1 + a2 (exact, no roots).
            margin = min(margin, np.min(1.0 - np.abs(den[:, 2])), np.min(1.0 + den[:, 2] - np.abs(den[:, 1])))
    assert margin > 0.0


def test_clustered_slow_poles_round_trip_through_the_sections():
    poles = [0.999, 0.998, 0.997, 0.9 + 0.05j, 0.9 - 0.05j, 0.5, -0.3]
    den, _ = blocks.sections(blocks.theta_from_poly(np.real(np.poly(poles)), len(poles)))
    got = np.sort_complex(np.concatenate([np.roots(r[: 3 if r[2] else 2]) for r in den]))
    assert np.max(np.abs(got - np.sort_complex(np.array(poles)))) < 1e-3


def test_unstable_start_is_reflected_inside():
    a = blocks.stabilise(np.poly([1.3, 0.5]))
    assert np.max(np.abs(np.roots(a))) < 1.0


def test_sos_rows_reproduce_the_transfer_function():
    rng = np.random.default_rng(3)
    den, _ = blocks.sections(rng.normal(size=5))
    b = np.array([0.0, 0.3, -0.2, 0.05])
    from scipy.signal import lfilter, sosfilt

    u = rng.standard_normal(400)
    ref = blocks.cascade(den, lfilter(b, [1.0], u))
    assert np.max(np.abs(sosfilt(blocks.sos_rows(b, den), u) - ref)) < 1e-10


def test_breakpoints_stay_increasing():
    rng = np.random.default_rng(1)
    x, _ = blocks.pwl_positions(rng.normal(scale=5.0, size=12))
    assert np.min(np.diff(x)) > 0


SPECS = [
    ChainSpec(2, 3, 2),
    ChainSpec(1, 2, 1, f_bp=5),
    ChainSpec(3, 2, 1, g_bp=4, delay=1),
    ChainSpec(2, 2, 1, f_bp=3, g_bp=4, h2=True, np2=2, nz2=1, delay=2),
    ChainSpec(1, 0, 2, g_bp=4, h2=True, np2=1, nz2=0),
]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: f"{s.n_inputs}in-f{s.f_bp}-g{s.g_bp}-h2{int(s.h2)}")
def test_analytic_jacobian_matches_central_differences(spec):
    rng = np.random.default_rng(2)
    theta = 0.5 * rng.standard_normal(spec.n_params)
    u = rng.standard_normal((300, spec.n_inputs))
    y, jac = Chain(spec, theta).jacobian(u)
    assert np.max(np.abs(y - Chain(spec, theta).simulate(u))) < 1e-12
    num = np.zeros_like(jac)
    h = 1e-6
    for k in range(spec.n_params):
        tp, tm = theta.copy(), theta.copy()
        tp[k] += h
        tm[k] -= h
        num[:, k] = (Chain(spec, tp).simulate(u) - Chain(spec, tm).simulate(u)) / (2 * h)
    assert np.max(np.abs(jac - num)) / np.max(np.abs(num)) < 1e-7
