"""Linear starting points: MISO ARX (least squares) and instrumental variables.

Both give a common denominator A and numerators B_i for

    A(q) y = sum_i B_i(q) q^-delay u_i + c

with B_i = b_0 + ... + b_nz q^-nz. Each recording contributes its own regressors (from rest,
no concatenation). Used only to start the output-error estimation.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from porosense.ident.blocks import stabilise


def _lag(x, k: int):
    out = np.zeros_like(x)
    if k < len(x):
        out[k:] = x[: len(x) - k]
    return out


def _regressors(u, y, n_poles, n_zeros, delay, y_for_lags=None):
    """Rows [-y lags | u_i lags ... | 1] of one recording; y lags taken from ``y_for_lags``."""
    yl = y if y_for_lags is None else y_for_lags
    cols = [-_lag(yl, k) for k in range(1, n_poles + 1)]
    for i in range(u.shape[1]):
        cols += [_lag(u[:, i], delay + k) for k in range(n_zeros + 1)]
    cols.append(np.ones(len(y)))
    return np.column_stack(cols)


def _unpack(theta, n_inputs, n_poles, n_zeros):
    a = np.concatenate([[1.0], theta[:n_poles]])
    bs = [theta[n_poles + i * (n_zeros + 1) : n_poles + (i + 1) * (n_zeros + 1)] for i in range(n_inputs)]
    return stabilise(a), bs, float(theta[-1])


def arx(us, ys, n_poles, n_zeros, delay=0):
    """Least-squares ARX over recordings; returns (a, [b_i], c)."""
    phi = np.vstack([_regressors(u, y, n_poles, n_zeros, delay) for u, y in zip(us, ys)])
    rhs = np.concatenate(ys)
    gram = phi.T @ phi
    theta = np.linalg.solve(gram + 1e-10 * np.trace(gram) / len(gram) * np.eye(len(gram)), phi.T @ rhs)
    return _unpack(theta, us[0].shape[1], n_poles, n_zeros)


def simulate_common(a, bs, c, u):
    """Simulate the common-denominator model from rest (offset c enters through 1/A)."""
    x = sum(lfilter(b, [1.0], u[:, i]) for i, b in enumerate(bs)) + c
    return lfilter([1.0], a, x)


def iv(us, ys, n_poles, n_zeros, delay=0, iterations=2):
    """Instrumental variables: y lags replaced by the ARX model's simulated output."""
    a, bs, c = arx(us, ys, n_poles, n_zeros, delay)
    for _ in range(iterations):
        phis, zs = [], []
        for u, y in zip(us, ys):
            sim = simulate_common(a, [np.concatenate([np.zeros(delay), b]) for b in bs], c, u)
            phis.append(_regressors(u, y, n_poles, n_zeros, delay))
            zs.append(_regressors(u, y, n_poles, n_zeros, delay, y_for_lags=sim))
        phi, z = np.vstack(phis), np.vstack(zs)
        try:
            theta = np.linalg.lstsq(z.T @ phi, z.T @ np.concatenate(ys), rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(theta)):
            break
        a, bs, c = _unpack(theta, us[0].shape[1], n_poles, n_zeros)
    return a, bs, c
