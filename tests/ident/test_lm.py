"""Levenberg-Marquardt on the normal equations against MINPACK's (scipy least_squares, "lm").

Problems: sums of damped exponentials and a Rosenbrock valley, with parameters, starts and
noise drawn from wide ranges (fixed seed); the reference is MINPACK's minimum from the same start.
"""

import numpy as np
import pytest
from scipy.optimize import least_squares

from porosense.ident.lm import levenberg_marquardt


def _exponentials(rng):
    """y = sum_k c_k exp(-t / tau_k) + noise, 2 terms; residuals and Jacobian in (c, log tau)."""
    t = np.linspace(0.0, 10.0, int(rng.integers(200, 5000)))
    truth = np.concatenate([rng.uniform(0.5, 5.0, 2), np.log(rng.uniform(0.2, 5.0, 2))])

    def model(p):
        c, tau = p[:2], np.exp(p[2:])
        return np.exp(-t[:, None] / tau[None, :]) @ c

    y = model(truth) + rng.uniform(0.001, 0.2) * rng.standard_normal(len(t))

    def fun(p):
        return model(p) - y

    def jac(p):
        c, tau = p[:2], np.exp(p[2:])
        e = np.exp(-t[:, None] / tau[None, :])
        return np.hstack([e, e * c[None, :] * t[:, None] / tau[None, :]])

    start = truth + rng.uniform(-1.0, 1.0, 4)
    return fun, jac, start


@pytest.mark.parametrize("seed", range(8))
def test_reaches_minpacks_minimum_on_exponential_fits(seed):
    fun, jac, start = _exponentials(np.random.default_rng(seed))
    ref = least_squares(fun, start, jac=jac, method="lm", max_nfev=2000, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    ours = levenberg_marquardt(fun, jac, start, max_nfev=2000, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    start_cost = float(np.sum(fun(start) ** 2))
    print(
        f"seed {seed}: start {start_cost:.4g}, MINPACK {2 * ref.cost:.8g} ({ref.nfev} evaluations), "
        f"ours {ours.cost:.8g} ({ours.nfev}, {ours.status})"
    )
    assert ours.cost <= start_cost
    # Same local minimum up to the tolerance (both from the same start; a different, lower
    # minimum would also pass).
    assert ours.cost <= 2 * ref.cost * (1 + 1e-6) + 1e-12
    assert np.isclose(ours.cost, float(np.sum(fun(ours.x) ** 2)), rtol=1e-12)


def test_rosenbrock_valley_and_budget():
    def fun(p):
        return np.array([10.0 * (p[1] - p[0] ** 2), 1.0 - p[0]])

    def jac(p):
        return np.array([[-20.0 * p[0], 10.0], [-1.0, 0.0]])

    out = levenberg_marquardt(fun, jac, np.array([-1.2, 1.0]), max_nfev=500, ftol=1e-14, xtol=1e-14, gtol=1e-14)
    assert np.allclose(out.x, [1.0, 1.0], atol=1e-6), out
    short = levenberg_marquardt(fun, jac, np.array([-1.2, 1.0]), max_nfev=5)
    assert short.nfev <= 5 and short.status == "max_nfev"
    assert short.cost <= float(np.sum(fun(np.array([-1.2, 1.0])) ** 2))
