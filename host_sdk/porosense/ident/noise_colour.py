"""Whether a model's noise path explains the colour of the measured period differences.

The models' process noise is white at g's input (:mod:`porosense.ident.chain`), so once the blocks
are fixed, the spectrum of the difference between two periods of a repeated input is fixed up to
its level: white noise through g (whose slope along the trajectory modulates it) and through H2.
The recording adds its own measurement noise at the output, which is white in the differences as
well. So the measured band powers of the period differences must be

    P_measured(band) = a * P_simulated(band) + b,    a > 0, b >= 0 (a density),

with P_simulated from white noise at the model's level (:mod:`porosense.ident.noise_level` gives
the bands and the measured differences). The relative misfit of that fit, each band weighted
by the standard error of its power (from its Welch segments, measured and simulated alike), is
chi-square distributed with (bands - free parameters) degrees of freedom when the model's noise
path is right: beyond its 1 - ALPHA quantile, white noise through the model's g and H2 does not
explain the measured differences. The bands count as independent: a covariance estimated from
the few segments of short records makes the test reject right models far too often, and Hann
segments correlate neighbouring bands only weakly (tests/ident/test_noise_colour.py measures the
level).

A diagnostic, reported with every process-noise fit from repeated periods. It tests the noise
model as much as the blocks: a coloured process noise refutes every split, and a split that
routes the noise through the whole dynamics can pass. So the selection does not use it: on the
measured WH benchmark the build with the best noise-free test error is refuted while a poor one
passes (``porosense bench ident --only builds``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls
from scipy.stats import chi2

from porosense.ident.chain import Chain
from porosense.ident.noise_level import PeriodData, _Bands, _noisy_output, _split

# Level at which a model's noise path is refuted: one-sided, as a misfit only grows when wrong.
ALPHA = 0.01
MC_PAIRS = 4  # simulated period pairs per measured one (their scatter enters each band's variance)


@dataclass
class ColourCheck:
    """The measured period-difference spectrum against a model's white-noise path."""

    statistic: float  # weighted squared misfit of the band powers (chi-square under the model)
    dof: int  # degrees of freedom
    p_value: float
    ratio_db: np.ndarray  # simulated (level fitted, measurement noise added) / measured, per band, dB
    output_noise: float  # fitted measurement-noise density b, as a fraction of the mean measured density

    @property
    def refuted(self) -> bool:
        """Whether the period differences refute the model's noise path at ALPHA."""
        return bool(self.p_value < ALPHA)

    def describe(self) -> str:
        return (
            f"period-difference colour: misfit {self.statistic:.1f} on {self.dof} dof, p = {self.p_value:.2g} "
            f"({'refuted' if self.refuted else 'not refuted'} at {100 * ALPHA:g} %)"
        )

    def to_dict(self) -> dict:
        return {
            "statistic": float(self.statistic),
            "dof": int(self.dof),
            "p_value": float(self.p_value),
            "refuted": self.refuted,
            "ratio_db": np.round(self.ratio_db, 2).tolist(),
            "output_noise": float(self.output_noise),
        }


def band_means(bands: _Bands, diffs) -> tuple[np.ndarray, np.ndarray]:
    """(mean power of each compared band, relative variance of that mean) over the Welch
    segments of ``diffs`` (:meth:`noise_level._Bands.segment_powers`).

    Neighbouring segments overlap by half, so the variance of the mean over K segments is
    (c0 + 2 c1) / K with c0 the segments' variance and c1 the covariance of neighbours (segments
    further apart are independent for noise far shorter than a segment); never below c0 / K, so
    that a few segments cannot make a band look more certain than independent ones would."""
    per = [seg[:, bands.used] for seg in bands.segment_powers(diffs)]
    k = sum(len(s) for s in per)
    if k < 3:
        raise ValueError("too few Welch segments in the period differences (at least 3)")
    mean = np.concatenate(per).mean(axis=0)
    dev = [s - mean for s in per]
    c0 = sum(np.sum(d * d, axis=0) for d in dev) / (k - 1)
    c1 = sum(np.sum(d[1:] * d[:-1], axis=0) for d in dev) / (k - 1)
    var = np.maximum(c0 + 2 * c1, c0) / k
    return mean, var / mean**2


def check(periods: PeriodData, spec, theta, us, seed: int = 0) -> ColourCheck:
    """Test the period differences of ``periods`` against the model (``spec``, ``theta``, with
    process noise; normalised units) simulated with white noise at its own level."""
    chain = Chain(spec, theta)
    sigma = chain.g_sigma
    if not sigma > 0:
        raise ValueError("the model has no process noise")
    rng = np.random.default_rng(seed)
    simulated = []
    for i, p, _ in periods.records:
        x = chain.linear_sum(us[i])
        for _ in range(MC_PAIRS):
            y = [_noisy_output(chain, x, sigma * rng.standard_normal(len(x))) for _ in range(2)]
            first, second = _split(y[0], p, periods.skip), _split(y[1], p, periods.skip)
            simulated += [b - a for a, b in zip(first[0], second[1])]
    measured = [d for _, _, ds in periods.records for d in ds]
    bands = periods.require_bands()
    m, var_m = band_means(bands, measured)
    s, var_s = band_means(bands, simulated)
    # Relative residual r = 1 - (a s + b) / m per band, each weighted by its standard error.
    w = 1.0 / np.sqrt(var_m + var_s)
    design = np.column_stack([s / m, 1.0 / m])
    coef, _ = nnls(w[:, None] * design, w)
    free = int(np.sum(coef > 0))
    fitted = design @ coef
    stat = float(np.sum((w * (1.0 - fitted)) ** 2))
    dof = max(len(m) - max(free, 1), 1)
    return ColourCheck(
        stat,
        dof,
        float(chi2.sf(stat, dof)),
        10 * np.log10(np.maximum(fitted, 1e-12)),
        float(coef[1] * len(m) / np.sum(m)),
    )
