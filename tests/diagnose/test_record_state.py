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
