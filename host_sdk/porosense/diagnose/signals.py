"""Signal-derived regressors and filters used by the residual tests and the extensions.

All functions act on one record at a time (1-D arrays sampled at a constant rate), so that
filters start from rest at the beginning of every record and never run across the joint
between two files.
"""

from __future__ import annotations

import numpy as np
from scipy import signal


def rest_level(x: np.ndarray, hold: int = 5, tol: float = 0.01) -> float:
    """The level a record is taken to have rested at before its first sample.

    A record that starts on a hold (its first ``hold`` samples within ``tol`` of its span of each
    other) or at one of its extremes (a step or a ramp out of rest) has rested at its first
    value. One that starts in the middle of its range while moving (a snippet of a periodic or
    random excitation) has no such level: its mean, where a zero-mean excitation's filters start.
    """
    x = np.asarray(x, dtype=float)
    if len(x) == 0:
        return 0.0
    span = float(np.ptp(x)) or 1.0
    head = x[: min(hold, len(x))]
    at_extreme = min(abs(x[0] - x.min()), abs(x[0] - x.max())) <= tol * span
    return float(x[0]) if float(np.ptp(head)) <= tol * span or at_extreme else float(np.mean(x))


def first_order_lag(x: np.ndarray, pole: float) -> np.ndarray:
    """Unit-DC-gain first-order lag (1 - a) / (1 - a q^-1) of ``x``; a = exp(-ts / tau)."""
    return signal.lfilter([1.0 - pole], [1.0, -pole], np.asarray(x, dtype=float))


def hinge_basis(x: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Columns max(0, x - knot) for each knot: with x itself they span every PWL map."""
    x = np.asarray(x, dtype=float)
    return np.maximum(0.0, x[:, None] - np.asarray(knots, dtype=float)[None, :])


def quantile_knots(x: np.ndarray, n: int) -> np.ndarray:
    """``n`` knots at evenly spaced inner quantiles of ``x`` (unique, increasing)."""
    q = np.linspace(0.0, 1.0, n + 2)[1:-1]
    return np.unique(np.quantile(x, q))


def cosine_trend_basis(n: int, n_terms: int) -> np.ndarray:
    """Slow cosines cos(pi k (i + 0.5) / n), k = 1..n_terms: trends longer than n / n_terms."""
    i = (np.arange(n) + 0.5) / max(n, 1)
    return np.column_stack([np.cos(np.pi * k * i) for k in range(1, n_terms + 1)])


def shift(x: np.ndarray, lag: int) -> np.ndarray:
    """x delayed by ``lag`` samples (lag > 0), the first samples holding x[0]."""
    x = np.asarray(x, dtype=float)
    if lag <= 0:
        return x.copy()
    return np.concatenate([np.full(min(lag, len(x)), x[0]), x[: max(len(x) - lag, 0)]])


def hampel(x: np.ndarray, half_window: int = 3, n_sigma: float = 5.0):
    """Replace isolated spikes by the local median; returns (cleaned, mask of replaced samples).

    A sample is a spike when it differs from the median of its +-half_window neighbours by more
    than n_sigma robust standard deviations of the first differences (MAD / 0.6745 / sqrt 2).
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    if n < 2 * half_window + 1:
        return x.copy(), np.zeros(n, bool)
    pad = np.pad(x, half_window, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(pad, 2 * half_window + 1)
    med = np.median(windows, axis=1)
    d = np.diff(x)
    sigma = 1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0)
    if sigma <= 0:
        sigma = np.std(d) / np.sqrt(2.0) or 1e-12
    mask = np.abs(x - med) > n_sigma * sigma
    out = x.copy()
    out[mask] = med[mask]
    return out, mask


def fit_ar(x: np.ndarray, max_order: int = 10) -> np.ndarray:
    """AR polynomial [1, a1, ..., ap] of x (Yule-Walker via Levinson-Durbin), order by BIC <= max_order."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = len(x)
    max_order = int(min(max_order, max(0, n // 4 - 3)))
    r = autocorr(x, max_order) * (np.mean(x * x) if n else 0.0)
    if n == 0 or r[0] <= 0:
        return np.array([1.0])
    a = np.array([1.0])
    err = r[0]
    best = (np.log(err), a)
    for p in range(1, max_order + 1):
        k = -np.dot(a, r[p:0:-1]) / err
        a = np.concatenate([a, [0.0]])
        a = a + k * a[::-1]
        err *= 1.0 - k * k
        if err <= 0:
            break
        bic = np.log(err) + p * np.log(n) / n
        if bic < best[0]:
            best = (bic, a.copy())
    return best[1]


def whiten(x: np.ndarray, ar: np.ndarray) -> np.ndarray:
    """Apply the AR polynomial ``ar`` as an FIR filter and drop the start-up samples."""
    p = len(ar) - 1
    return signal.lfilter(ar, [1.0], np.asarray(x, dtype=float), axis=0)[p:]


def autocorr(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation r(0..max_lag) of x (biased estimator, r(0) = 1)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = len(x)
    f = np.fft.rfft(x, 2 * n)
    acov = np.fft.irfft(f * np.conj(f))[: max_lag + 1] / n
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


def crosscorr(x: np.ndarray, y: np.ndarray, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Sample cross-correlation r_xy(tau) = corr(x[k], y[k + tau]) for tau = -max_lag..max_lag.

    Positive tau: y follows x (for x an input and y a residual, unmodelled dynamics of x).
    """
    x = np.asarray(x, dtype=float) - np.mean(x)
    y = np.asarray(y, dtype=float) - np.mean(y)
    n = len(x)
    denom = np.sqrt(np.sum(x * x) * np.sum(y * y)) or 1.0
    fx = np.fft.rfft(x, 2 * n)
    fy = np.fft.rfft(y, 2 * n)
    c = np.fft.irfft(np.conj(fx) * fy, 2 * n)
    lags = np.arange(-max_lag, max_lag + 1)
    return lags, c[lags % (2 * n)] / denom
