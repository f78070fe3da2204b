"""Parametrised blocks: stability by construction and exact Jacobians."""

import numpy as np
import pytest

from porosense.ident import blocks
from porosense.ident.chain import Chain, ChainSpec


def test_every_parameter_vector_gives_a_stable_denominator():
    rng = np.random.default_rng(0)
    worst = 0.0
    for n in range(1, 11):
        for _ in range(50):
            a = blocks.stable_poly(rng.normal(scale=1.5, size=n))
            worst = max(worst, np.max(np.abs(np.roots(a))))
    assert worst < 1.0


def test_saturated_parameters_still_pass_the_schur_cohn_test():
    # np.roots is too inaccurate for 10 clustered poles; the Schur-Cohn recursion is exact.
    worst = 0.0
    for sign in (1.0, -1.0):
        a = blocks.stable_poly(np.full(10, 40.0 * sign))
        worst = max(worst, np.max(np.abs(blocks._step_down(a))))
    assert worst < 1.0


def test_denominator_round_trip_through_reflection_coefficients():
    a = np.poly([0.95, 0.5 + 0.4j, 0.5 - 0.4j, -0.3])
    back = blocks.stable_poly(blocks.poly_to_theta(a))
    assert np.max(np.abs(back - a)) < 1e-9


def test_unstable_start_is_reflected_inside():
    a = blocks.stabilise(np.poly([1.3, 0.5]))
    assert np.max(np.abs(np.roots(a))) < 1.0


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
