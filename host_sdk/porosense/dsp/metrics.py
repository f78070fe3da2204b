"""The paper's metrics (docs/design.md), on simulated output (never one-step prediction).

fit   = 100 (1 - ||y - yhat|| / ||y - mean(y)||)      NRMSE fit, %
RMS % = 100 / max|y| * sqrt(mean((y - yhat)^2))        % of the output's peak
"""

from __future__ import annotations

import numpy as np


def fit_percent(y, yhat) -> float:
    """NRMSE fit: 100 (1 - ||y - yhat|| / ||y - mean(y)||).

    Parameters
    ----------
    y, yhat : array_like
        Measured and simulated output, same length and unit (flattened).

    Returns
    -------
    float
        Fit in % (100 is perfect; can be negative); NaN for a constant ``y``.
    """
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    den = np.linalg.norm(y - y.mean())
    if den == 0.0:
        return float("nan")
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den))


def rms_percent(y, yhat) -> float:
    """RMS error in % of the output's peak, as the paper reports it (100 / max(y) RMSE).

    The peak is taken as max(|y|): for outputs that swing both ways or stay negative (a tilt
    angle), max(y) can be near zero and would blow the figure up.

    Parameters
    ----------
    y, yhat : array_like
        Measured and simulated output, same length and unit (flattened).

    Returns
    -------
    float
        RMS error in % of max|y|; NaN for an all-zero ``y``.
    """
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    peak = np.max(np.abs(y))
    if peak == 0.0:
        return float("nan")
    return float(100.0 / peak * np.sqrt(np.mean((y - yhat) ** 2)))


def rmse(y, yhat) -> float:
    """Root-mean-square error.

    Parameters
    ----------
    y, yhat : array_like
        Measured and simulated output, same length and unit (flattened).

    Returns
    -------
    float
        RMS error in the unit of ``y``.
    """
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    return float(np.sqrt(np.mean((y - yhat) ** 2)))
