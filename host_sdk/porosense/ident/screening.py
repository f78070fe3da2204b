"""The part of long records that candidates are screened on.

Ranking orders and structures does not need every sample: with N scored samples the excess
error of a fitted model over its best parameters is about p / N of the noise power (p
parameters), 0.1 % for p = 30 at N = 30,000, far below the differences the selection acts
on. So beyond ``screen_samples`` scored samples the candidates are fitted on a subset of that
size, scored on all the estimation and validation samples, and only the finalists are refined
on all of them (their fit from the subset is already close: few evaluations). The cost of the
search then grows with the records only through the finalists' refinement and the scoring,
both O(N) per evaluation.

The subset is a few windows spread over every record (a prefix alone would miss what comes
later in a long recording), in proportion to the records' lengths. Every window is simulated
from rest, so it begins ``warmup`` samples before the part that is scored: the time the
slowest pole of a low-order linear fit takes to decay to 1 % (at most half the window).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WINDOWS_PER_RECORD = 4
MIN_SCORED_PER_WINDOW = 2_000
SETTLE_FRACTION = 0.01  # a transient counts as gone once decayed to 1 %


@dataclass(frozen=True)
class Subset:
    """Windows (record, start, stop) of the estimation records; each is simulated from rest and
    scored past its first ``skip`` samples."""

    windows: tuple
    skip: int
    samples: int  # scored samples in all windows
    of_samples: int  # scored samples of the records it was taken from

    def take(self, us, ys) -> tuple[list, list]:
        """(inputs, outputs) of the windows."""
        return [us[r][a:b] for r, a, b in self.windows], [ys[r][a:b] for r, a, b in self.windows]

    def describe(self) -> str:
        return (
            f"candidates screened on {self.samples:,} of {self.of_samples:,} samples ({len(self.windows)} windows, "
            f"each simulated {self.skip} samples before it is scored), finalists refined on all"
        )


def settle_samples(poles, cap: int) -> int:
    """Samples for the slowest of ``poles`` (z-plane) to decay to SETTLE_FRACTION, at most ``cap``."""
    radius = float(np.max(np.abs(poles))) if len(poles) else 0.0
    if not 0.0 < radius < 1.0:
        return cap if radius >= 1.0 else 1
    return int(min(cap, max(1, np.ceil(np.log(SETTLE_FRACTION) / np.log(radius)))))


def screening_subset(lengths, skip: int, budget: int, settle) -> Subset | None:
    """The windows to screen on, or None when the records hold at most ``budget`` scored samples.

    Parameters
    ----------
    lengths : list of int
        Samples of every estimation record.
    skip : int
        Leading samples of every record that are not scored.
    budget : int
        Scored samples the subset holds (about).
    settle : callable
        ``settle(cap) -> samples`` a window needs before it is scored (at most ``cap``).
    """
    scored = [max(n - skip, 0) for n in lengths]
    total = sum(scored)
    if budget <= 0 or total <= budget:
        return None
    shares = [budget * s / total for s in scored]
    per_window = [s / max(1, min(WINDOWS_PER_RECORD, int(s // MIN_SCORED_PER_WINDOW))) if s > 0 else 0 for s in shares]
    scored_len = int(max(min(max(per_window), max(shares)), 1))
    warm = max(skip, settle(scored_len))
    windows, samples = [], 0
    for r, (n, share) in enumerate(zip(lengths, shares)):
        if share <= 0:
            continue
        k = max(1, min(WINDOWS_PER_RECORD, int(share // MIN_SCORED_PER_WINDOW)))
        length = int(round(share / k))
        if length <= 0:
            continue
        # Scored parts spread evenly over [skip, n); each window starts warm samples earlier.
        first, last = skip, n - length
        starts = np.linspace(first, max(first, last), k).round().astype(int)
        for a in starts:
            lo = max(int(a) - warm, 0)
            hi = min(int(a) + length, n)
            if hi - lo - warm < 10:
                continue
            windows.append((r, lo, hi))
            samples += hi - lo - warm
    if not windows:
        return None
    # Windows that start at the record's beginning are short of warm-up only where the record
    # itself starts (from rest, as the full fit simulates it).
    return Subset(tuple(windows), warm, samples, total)
