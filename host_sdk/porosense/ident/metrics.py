"""Metrics of identification: the paper's fit and RMS % (shared with quant and diagnose in
:mod:`porosense.dsp.metrics`), the standard error of a fit and information criteria."""

from __future__ import annotations

import numpy as np

from porosense.dsp.metrics import fit_percent, rms_percent, rmse  # noqa: F401  (the paper's metrics, shared)


def relative_standard_error(n_samples: int) -> float:
    """Relative standard error of an error norm ||e|| over ``n_samples`` independent Gaussian
    residuals: 1 / sqrt(2 n) (dimensionless). The squared norm's is twice that. Both tie rules
    of the engine use it: candidates of the order search within one standard error of the best
    fit (a fit of F % has one of (100 - F) / sqrt(2 n) points), and process-noise builds within
    one standard error of the lowest squared error."""
    return 1.0 / np.sqrt(2.0 * max(int(n_samples), 1))


def information_criteria(sse: float, n_samples: int, n_params: int) -> tuple[float, float]:
    """AIC and BIC of a Gaussian least-squares fit.

    Parameters
    ----------
    sse : float
        Sum of squared errors (any unit squared; only ratios between fits of one data set matter).
    n_samples : int
        Samples scored, N.
    n_params : int
        Estimated parameters, p.

    Returns
    -------
    aic, bic : float
        N ln(SSE/N) + 2p and N ln(SSE/N) + p ln N.
    """
    n = max(int(n_samples), 1)
    base = n * np.log(max(sse, 1e-300) / n)
    return float(base + 2 * n_params), float(base + n_params * np.log(n))
