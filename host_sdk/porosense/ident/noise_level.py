"""The level of a process noise at g's input, measured from repeated periods of the input.

The expected output E[y | u] = H2(E_v g(H1 u + v)) does not fix the noise level: a smoother g
with less noise gives the same mean. Its second moment does. When a recording repeats its
input (a periodic excitation, as multisine experiments are run), the difference between two
periods, d = y_(k+1) - y_k, holds the noise alone, passed through g and H2. Given a model at
a trial noise level, the same difference is simulated with Gaussian noise (two independent
draws) and compared with the measured one in frequency bands:

- the noise spectrum's shape is unknown, so it is fitted first (piecewise constant over
  log-spaced bands, the simulated band powers matched to the measured ones by a
  multiplicative fixed-point update); the trial level fixes its variance;
- what remains is the ratio of simulated to measured power. It grows with the level, and the
  level at which it equals 1 is the estimate.

A model whose ratio stays away from 1 by more than CONSISTENCY_Z standard errors (the scatter
of the measured and simulated powers over their Welch segments) cannot reproduce the noise: its
blocks are refuted by the period differences, whatever its expected output fits.

Bands beyond the one where the measured power reaches 99.9 % of its total are left out: what is
there is the output's measurement noise, not the process noise. Everything works in the
normalised units of :mod:`porosense.ident.estimate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import spectrogram, welch

from porosense.ident import blocks
from porosense.ident.chain import Chain, block_filter

# Two periods count as a repeat when their inputs differ by less than this fraction of the
# input's RMS. Repeats of a generator agree to its noise (the WH benchmark: 0.03 %); two
# unrelated stretches of a random input differ by about sqrt(2) x the RMS.
REPEAT_TOLERANCE = 0.01
MAX_REPEATS = 8  # periods tried: N/2 .. N/MAX_REPEATS samples
SEGMENT = 256  # Welch segment (samples)
N_BANDS = 14  # log-spaced band edges over the Welch grid
POWER_KEPT = 0.999  # measured power the compared bands hold
SHAPE_ITERATIONS = 8
MC_PAIRS = 2  # simulated period pairs per measured one
# Two-sided 1 % quantile of the standard normal: a model whose simulated period power misses the
# measured one by more than this many standard errors cannot reproduce the noise at any level.
CONSISTENCY_Z = 2.576


def repeated_period(u, skip: int = 0) -> int:
    """Period (samples) of a recording ``u`` (N, n_inputs) that holds at least two whole
    repeats of its input, or 0. Periods N/2 .. N/8 are tried, the longest repeating kept; the
    first ``skip`` samples never count as a whole period (they hold the transient)."""
    u = np.asarray(u, dtype=float)
    u = u[:, None] if u.ndim == 1 else u
    n = len(u)
    rms = float(np.sqrt(np.mean(u**2))) or 1.0
    for k in range(2, MAX_REPEATS + 1):
        p = n // k
        if p <= max(skip, SEGMENT // 2):
            break
        d = u[p : k * p] - u[: (k - 1) * p]
        if float(np.sqrt(np.mean(d**2))) < REPEAT_TOLERANCE * rms:
            return p
    return 0


def _pairs(y, period: int, skip: int):
    """Differences between consecutive whole periods of ``y`` (the first past ``skip``)."""
    earlier, later = _split(y, period, skip)
    return [b - a for a, b in zip(earlier, later)]


@dataclass
class _Bands:
    edges: np.ndarray  # Welch-grid indices of the band edges
    used: np.ndarray  # bands compared (bool)

    def powers(self, diffs) -> np.ndarray:
        """Mean Welch density per band over the difference records ``diffs``."""
        total, weight = 0.0, 0
        for d in diffs:
            _, p = welch(d, nperseg=min(SEGMENT, len(d)))
            total = total + p * len(d)
            weight += len(d)
        p = np.asarray(total / weight)
        return np.array([p[a:b].mean() for a, b in zip(self.edges[:-1], self.edges[1:])])

    def segment_powers(self, diffs) -> list[np.ndarray]:
        """Per record of ``diffs`` at least a segment long, the mean density per band (all
        bands) of every half-overlapping Hann segment: an array (segments, bands)."""
        out = []
        for d in diffs:
            if len(d) < SEGMENT:
                continue
            _, _, p = spectrogram(d, nperseg=SEGMENT, noverlap=SEGMENT // 2, window="hann", mode="psd")
            out.append(np.array([p[a:b].mean(axis=0) for a, b in zip(self.edges[:-1], self.edges[1:])]).T)
        return out

    def relative_error(self, diffs) -> float:
        """Relative standard error of the compared power of ``diffs`` as :meth:`powers` averages
        it: the compared power of every Welch segment, whose mean has variance (c0 + 2 c1) / K
        for K segments (c0 their variance, c1 the covariance of neighbours, which overlap by half;
        segments further apart are independent for noise far shorter than a segment)."""
        width = np.diff(self.edges)[self.used]
        per_record = [seg[:, self.used] @ width for seg in self.segment_powers(diffs)]
        k = sum(len(p) for p in per_record)
        if k < 3:
            return float("inf")
        mean = np.concatenate(per_record).mean()
        dev = [p - mean for p in per_record]
        c0 = sum(float(d @ d) for d in dev) / (k - 1)
        c1 = sum(float(d[1:] @ d[:-1]) for d in dev) / (k - 1)
        return float(np.sqrt(max(c0 + 2 * c1, 0.0) / k) / mean)


@dataclass
class PeriodNoise:
    """What the repeated periods say about the process noise at a trial level."""

    sigma: float  # trial standard deviation at g's input (normalised units)
    power_ratio: float  # simulated / measured power of the period differences
    shape: np.ndarray  # noise density per compared band (relative, max 1)
    band_edges: np.ndarray  # band edges, cycles per sample
    shape_misfit: float  # largest |log| band ratio left after the shape fit
    n_pairs: int = 0
    ratio_error: float = float("nan")  # standard error of log(power_ratio): measured and simulated scatter
    extra: dict = field(default_factory=dict)


class PeriodData:
    """The measured period differences of the recordings that repeat their input."""

    def __init__(self, us, ys, skip: int = 0):
        self.records = []  # (index, period, measured differences)
        for i, (u, y) in enumerate(zip(us, ys)):
            p = repeated_period(u, skip)
            if p:
                diffs = _pairs(np.asarray(y, dtype=float), p, skip)
                if diffs:
                    self.records.append((i, p, diffs))
        self.skip = skip
        self.bands: _Bands | None = None  # None: no recording repeats its input
        if not self.records:
            return
        n_grid = SEGMENT // 2 + 1
        edges = np.unique(np.round(np.geomspace(1, n_grid, N_BANDS)).astype(int))
        bands = _Bands(edges, np.ones(len(edges) - 1, dtype=bool))
        measured = bands.powers([d for _, _, ds in self.records for d in ds])
        width = np.diff(edges)
        cum = np.cumsum(measured * width) / np.sum(measured * width)
        bands.used = np.r_[True, cum[:-1] < POWER_KEPT]
        self.bands, self.measured = bands, measured
        self.measured_error = bands.relative_error([d for _, _, ds in self.records for d in ds])

    def consistent(self, check: PeriodNoise, tolerance: float = 0.0) -> bool:
        """Whether a model's simulated period power (``check``) agrees with the measured one:
        |log ratio| within CONSISTENCY_Z standard errors (two-sided, 1 %) or ``tolerance``."""
        bound = max(tolerance, CONSISTENCY_Z * check.ratio_error)
        return bool(
            np.isfinite(check.power_ratio) and check.power_ratio > 0 and abs(np.log(check.power_ratio)) <= bound
        )

    def __bool__(self) -> bool:
        return bool(self.records)

    def require_bands(self) -> _Bands:
        """The frequency bands of the comparison; a ValueError when no recording repeats its input."""
        if self.bands is None:
            raise ValueError("no recording repeats its input: no period differences to compare")
        return self.bands

    @property
    def n_pairs(self) -> int:
        return sum(len(ds) for _, _, ds in self.records)

    def describe(self) -> str:
        periods = sorted({p for _, p, _ in self.records})
        return (
            f"{len(self.records)} recording(s) repeat their input (period {', '.join(map(str, periods))} "
            f"samples): {self.n_pairs} period difference(s)"
        )

    def evaluate(self, spec, theta, us, sigma: float, seed: int = 0) -> PeriodNoise:
        """Fit the noise spectrum's shape for the model (``spec``, ``theta``) with its noise at
        ``sigma`` and return the simulated/measured power ratio of the period differences."""
        chain = Chain(spec, theta)
        bands = self.require_bands()
        used, edges = bands.used, bands.edges
        shape = np.where(used, 1.0, 1e-6)
        inputs = [(chain.linear_sum(us[i]), p) for i, p, _ in self.records]
        ratio, misfit = np.nan, np.inf
        for _ in range(SHAPE_ITERATIONS):
            rng = np.random.default_rng(seed)  # the same draws at every step: a smooth update
            simulated = []
            for x, p in inputs:
                for _ in range(MC_PAIRS):
                    y = [_noisy_output(chain, x, _coloured(shape, edges, sigma, len(x), rng)) for _ in range(2)]
                    # Period k of one draw against period k + 1 of the other: independent noise,
                    # the same input, as in the measured pairs.
                    first, second = _split(y[0], p, self.skip), _split(y[1], p, self.skip)
                    simulated += [b - a for a, b in zip(first[0], second[1])]
            sim = bands.powers(simulated)
            m, s = self.measured[used], sim[used]
            ratio = float(np.sum(s * np.diff(edges)[used]) / np.sum(m * np.diff(edges)[used]))
            update = (m / m.sum()) / (s / s.sum())
            misfit = float(np.max(np.abs(np.log(update))))
            shape[used] *= update
            shape /= shape.max()
        error = float(np.hypot(self.measured_error, bands.relative_error(simulated)))
        return PeriodNoise(sigma, ratio, shape[used].copy(), edges / SEGMENT, misfit, self.n_pairs, error)


def _split(y, period: int, skip: int):
    """Consecutive whole periods as (earlier, later) windows matching :func:`_pairs`."""
    n_periods = len(y) // period
    start = skip if skip < period else period  # the first period only past the transient
    earlier, later = [], []
    for k in range(n_periods - 1):
        lo = start if k == 0 else 0
        if period - lo >= SEGMENT:
            earlier.append(y[k * period + lo : (k + 1) * period])
            later.append(y[(k + 1) * period + lo : (k + 2) * period])
    return earlier, later


def _coloured(shape, edges, sigma: float, n: int, rng) -> np.ndarray:
    """Gaussian noise of ``n`` samples, density piecewise constant over the bands, std sigma."""
    freq = np.fft.rfftfreq(n)
    band = np.clip(np.searchsorted(edges / SEGMENT, freq, side="right") - 1, 0, len(shape) - 1)
    v = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * np.sqrt(shape[band]), n)
    return v * (sigma / (np.std(v) or 1.0))


def _noisy_output(chain: Chain, x, v) -> np.ndarray:
    """H2(g(x + v)) for the model's blocks (normalised units, no offset)."""
    assert chain.g is not None  # process noise enters at g's input: every noise spec has g
    z = blocks.pwl_eval(chain.g[0], chain.g[1], x + v)
    if chain.h2 is not None:
        b, den, _ = chain.h2
        z = block_filter(b, den, z)
    return z
