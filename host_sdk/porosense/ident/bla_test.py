"""Which linear orders the nonparametric best linear approximation (BLA) refutes.

Periodic multisine experiments with several realisations (independent random phases, the same
period) give the BLA frequency by frequency with its variance: at each excited frequency k,
G_r(k) = Y_r(k) / U_r(k) over one steady-state period of realisation r, their mean G(k) and the
variance of that mean s2(k) from the spread over the M realisations (it holds the measurement
noise, the process noise and the stochastic nonlinear distortions alike). A linear model of the
right order has a frequency response within that scatter: per frequency
|G_model - G|^2 / s2 follows an F(2, 2(M - 1)) distribution (mean (M - 1) / (M - 2)), and over
F frequencies their mean is close to normal. A model whose mean lies beyond the one-sided
quantile of that distribution (default 1 %) is refuted: its dynamics miss what the BLA shows.

This needs no validation data, so it ranks orders where validation cannot: when the records
are dominated by a process noise, every candidate validates alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import f as f_dist
from scipy.stats import norm

from porosense.ident.noise_level import repeated_period

MIN_REALISATIONS = 4  # F(2, 2(M - 1)) has a finite variance only for M >= 4
EXCITED = 0.01  # a frequency is excited when |U| exceeds this fraction of its peak in every record
MIN_FREQUENCIES = 20


@dataclass
class NonparametricBLA:
    """The BLA at the excited frequencies of M realisations, with the variance of its mean."""

    bins: np.ndarray  # DFT bins of one period
    period: int  # samples
    mean: np.ndarray  # complex, output units per input unit
    variance: np.ndarray  # variance of the mean (|.|^2)
    realisations: int

    @classmethod
    def from_records(cls, us, ys, skip: int = 0) -> NonparametricBLA | None:
        """The BLA of single-input records that repeat their input with one common period
        (the last whole period of each, past ``skip`` and the transient), or None when there
        are fewer than MIN_REALISATIONS such records or too few excited frequencies."""
        us = [np.asarray(u, dtype=float) for u in us]
        if not us or any(u.ndim == 2 and u.shape[1] != 1 for u in us):
            return None
        periods = [repeated_period(u, skip) for u in us]
        if len(set(periods)) != 1 or periods[0] == 0 or len(us) < MIN_REALISATIONS:
            return None
        p = periods[0]
        u_f = np.array([np.fft.rfft(np.ravel(u)[-p:]) for u in us])
        y_f = np.array([np.fft.rfft(np.asarray(y, dtype=float)[-p:]) for y in ys])
        peak = np.abs(u_f).max(axis=1, keepdims=True)
        bins = np.where(np.all(np.abs(u_f) > EXCITED * peak, axis=0))[0]
        bins = bins[bins > 0]  # DC carries the offset, not the dynamics
        if len(bins) < MIN_FREQUENCIES:
            return None
        g = y_f[:, bins] / u_f[:, bins]
        m = len(us)
        return cls(bins, p, g.mean(axis=0), np.var(g, axis=0, ddof=1) / m, m)

    def misfit(self, model, us) -> float:
        """Mean of |G_model - G|^2 / s2 over the excited frequencies; ``model`` simulated from
        rest over ``us`` (the records the BLA came from) and read in its last period."""
        gm = []
        for u in us:
            u2 = np.asarray(u, dtype=float)
            u2 = u2[:, None] if u2.ndim == 1 else u2
            yh = np.asarray(model.predict(u=u2)).ravel()
            gm.append(np.fft.rfft(yh[-self.period :])[self.bins] / np.fft.rfft(u2[-self.period :, 0])[self.bins])
        return float(np.mean(np.abs(np.mean(gm, axis=0) - self.mean) ** 2 / self.variance))

    def threshold(self, alpha: float = 0.01) -> float:
        """The misfit a right model exceeds with probability ``alpha`` (normal approximation of
        the mean of F(2, 2(M - 1)) over the frequencies)."""
        d2 = 2 * (self.realisations - 1)
        mean, var = f_dist.stats(2, d2, moments="mv")
        return float(mean + norm.isf(alpha) * np.sqrt(var / len(self.bins)))

    def describe(self) -> str:
        return f"nonparametric BLA of {self.realisations} realisations at {len(self.bins)} excited frequencies"
