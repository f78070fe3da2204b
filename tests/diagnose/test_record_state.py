"""The recording state beside an extension (porosense.diagnose.calibrate): the residual's
effective sample size and the posterior refit of a record's state.

Data: an AR(1) process and a linear-Gaussian state model drawn here with fixed seeds, whose
effective size and posterior maximum are known in closed form.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose.calibrate import StateColumns, n_effective


def test_n_effective_of_an_ar1_residual_is_its_theoretical_size():
    """AR(1) with coefficient phi: N (1 - phi) / (1 + phi) effective samples (bound: 15 %)."""
    rng = np.random.default_rng(0)
    n, phi = 20000, 0.9
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0]
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    theory = n * (1 - phi) / (1 + phi)
    assert abs(n_effective(x) / theory - 1) < 0.15, (n_effective(x), theory)
    # white noise: every sample counts (bound: 10 %)
    assert abs(n_effective(e) / n - 1) < 0.1, n_effective(e)


def test_state_refit_is_the_posterior_maximum():
    """refit(r) maximises the posterior |r - S d|^2 + |R d - t|^2: equal to the normal
    equations' solution to 1e-9 relative, and moved() keeps the prior on the total state."""
    rng = np.random.default_rng(1)
    S = rng.normal(size=(500, 3))
    R = np.diag([2.0, 0.5, 1.0])
    t = np.array([0.3, -1.0, 0.0])
    r = S @ np.array([1.0, -2.0, 0.5]) + rng.normal(size=500)
    d = StateColumns(S, R, t).refit(r)
    closed = np.linalg.solve(S.T @ S + R.T @ R, S.T @ r + R.T @ t)
    assert np.allclose(d, closed, rtol=1e-9, atol=1e-12)
    # after applying d the residual is r - S d, and the posterior's maximum is then 0
    assert np.allclose(StateColumns(S, R, t).moved(d).refit(r - S @ d), 0.0, atol=1e-9)


def test_state_fit_is_the_records_own_rule():
    """fit(r) is the least squares of r on S bounded to the prior's 99 % interval about its mean
    (|z| <= 2.576 sd, the rule calibrate fits a record's state by), the present value given by the
    prior's pull t: inside the interval it is the unbounded least squares (to 1e-9), beyond it the
    state stops at the interval's edge (to 1e-9) and no other point of the box fits better."""
    from porosense.diagnose.calibrate import Z_PRIOR

    rng = np.random.default_rng(2)
    S = rng.normal(size=(400, 2))
    sd = np.array([1.0, 0.5])
    R = np.diag(1.0 / sd)  # data weight 1
    now = np.array([0.5, -0.2])  # present values: t = -R now
    cols = StateColumns(S, R, -R @ now, ("gain", "offset"), sd)
    # a small increment: the unbounded least squares
    r = S @ np.array([0.3, 0.1]) + 0.01 * rng.normal(size=400)
    assert np.allclose(cols.fit(r), np.linalg.lstsq(S, r, rcond=None)[0], rtol=1e-9, atol=1e-12)
    # an increment that would take the gain state beyond +2.576: it stops at the edge
    r = S @ np.array([5.0, 0.1]) + 0.01 * rng.normal(size=400)
    d = cols.fit(r)
    assert abs(now[0] + d[0] - Z_PRIOR * sd[0]) < 1e-9, d
    sse = float(np.sum((r - S @ d) ** 2))
    for probe in rng.uniform(-Z_PRIOR, Z_PRIOR, size=(200, 2)) * sd - now:
        assert float(np.sum((r - S @ probe) ** 2)) >= sse - 1e-9
