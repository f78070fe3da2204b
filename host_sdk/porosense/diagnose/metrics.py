"""Fit metrics of docs/design.md (simulation fit, never one-step prediction)."""

from __future__ import annotations

import numpy as np


def fit_percent(y, yhat) -> float:
    """NRMSE fit: 100 (1 - ||y - yhat|| / ||y - mean(y)||), in %."""
    y = np.asarray(y, float)
    yhat = np.asarray(yhat, float)
    den = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den)) if den > 0 else float("nan")


def rms_percent(y, yhat) -> float:
    """RMS error in % of the largest output magnitude: 100 / max|y| sqrt(mean((y - yhat)^2))."""
    y = np.asarray(y, float)
    yhat = np.asarray(yhat, float)
    peak = np.max(np.abs(y))
    return float(100.0 / peak * np.sqrt(np.mean((y - yhat) ** 2))) if peak > 0 else float("nan")
