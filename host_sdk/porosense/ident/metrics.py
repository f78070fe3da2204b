"""The paper's metrics (docs/design.md), on simulation output, per recording and output.

fit   = 100 (1 - ||y - yhat|| / ||y - mean(y)||)            (NRMSE fit, %)
RMS % = 100 / max(y) * sqrt(mean((y - yhat)^2))              (% of the output's maximum)
"""

from __future__ import annotations

import numpy as np


def fit_percent(y, yhat) -> float:
    """NRMSE fit in % (100 is perfect, can be negative). ``y``, ``yhat`` 1-D, same unit."""
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    den = np.linalg.norm(y - y.mean())
    if den == 0.0:
        return float("nan")
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den))


def relative_standard_error(n_samples: int) -> float:
    """Relative standard error of an error norm ||e|| over ``n_samples`` independent Gaussian
    residuals: 1 / sqrt(2 n) (dimensionless). The squared norm's is twice that. Both tie rules
    of the engine use it: candidates of the order search within one standard error of the best
    fit (a fit of F % has one of (100 - F) / sqrt(2 n) points), and process-noise builds within
    one standard error of the lowest squared error."""
    return 1.0 / np.sqrt(2.0 * max(int(n_samples), 1))


def rms_percent(y, yhat) -> float:
    """RMS error in % of the output's peak, as the paper reports it (100 / max(y) RMSE).

    The peak is taken as max(|y|): for outputs that swing both ways or stay negative (a tilt
    angle), max(y) can be near zero and would blow the figure up.
    """
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    peak = np.max(np.abs(y))
    if peak == 0.0:
        return float("nan")
    return float(100.0 / peak * np.sqrt(np.mean((y - yhat) ** 2)))


def rmse(y, yhat) -> float:
    """Root-mean-square error in the unit of ``y``."""
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    return float(np.sqrt(np.mean((y - yhat) ** 2)))


def information_criteria(sse: float, n_samples: int, n_params: int) -> tuple[float, float]:
    """(AIC, BIC) of a Gaussian least-squares fit: N ln(SSE/N) + 2p, N ln(SSE/N) + p ln N."""
    n = max(int(n_samples), 1)
    base = n * np.log(max(sse, 1e-300) / n)
    return float(base + 2 * n_params), float(base + n_params * np.log(n))
