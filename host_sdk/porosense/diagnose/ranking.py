"""The ranking rule: held-out gain first, and the simplest extension among gains that overlap.

Every found cause has a held-out gain confirmed against its own baseline (see :mod:`.engine`).
Its per-sample improvement on the validation records, d_c[k] = (y - baseline)^2 -
(y - extension)^2, carries the uncertainty of that gain. The found causes are ordered by
repeating:

1. the candidate with the largest gain (fit points) is found;
2. every remaining candidate whose improvement is not below that one's at one-sided 5 % / m (m
   candidates compared with it at this step, Bonferroni; batch means of d_best - d_c,
   :func:`.stats.mean_positive_test`) overlaps it;
3. among the overlapping candidates the one with the fewest parameters wins (then the larger
   gain, then the name); it is placed next and removed.

A cause is placed above one with a larger gain only when the two gains overlap and its
extension is simpler. Causes that are not
found (no significant test, evidence that disagrees with the name, or no confirmed gain) come
after ``none``, by gain, so a cause whose extension does not gain is never ranked above one
that does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from porosense.diagnose import stats


@dataclass
class Candidate:
    """A found cause: its gain (fit points), improvement per validation sample, parameter count."""

    cause: str
    gain: float
    improvement: np.ndarray
    n_params: int


@dataclass
class Step:
    """Why ``winner`` was placed where it is: the largest gain then, and the overlap test."""

    winner: str
    largest: str
    overlapping: list
    t_against_largest: float
    p_against_largest: float
    #: per other remaining candidate: (t, one-sided p) of its improvement being below the largest's
    below_largest: dict


OVERLAP_ALPHA = 0.05


def _below(best: Candidate, other: Candidate, m: int) -> stats.GainTest:
    """Is ``other``'s improvement below ``best``'s? (one-sided at OVERLAP_ALPHA / m, batch means)"""
    return stats.mean_positive_test(best.improvement - other.improvement, alpha=OVERLAP_ALPHA / max(m, 1))


def rank(candidates: list) -> tuple[list, list]:
    """(causes in rank order, one :class:`Step` per placed cause) for the found ``candidates``."""
    remaining = list(candidates)
    order, steps = [], []
    while remaining:
        best = max(remaining, key=lambda c: (c.gain, -c.n_params, c.cause))
        tests = {c.cause: _below(best, c, len(remaining) - 1) for c in remaining if c is not best}
        overlap = [best] + [c for c in remaining if c is not best and not tests[c.cause].confirmed]
        winner = min(overlap, key=lambda c: (c.n_params, -c.gain, c.cause))
        t = tests.get(winner.cause)
        steps.append(
            Step(
                winner.cause,
                best.cause,
                [c.cause for c in overlap],
                float(t.t) if t else float("nan"),
                float(t.p) if t else float("nan"),
                {c: (round(float(v.t), 3), float(v.p)) for c, v in tests.items()},
            )
        )
        order.append(winner.cause)
        remaining.remove(winner)
    return order, steps


RULE = (
    "found causes (test significant at alpha / K, evidence that agrees with the name, held-out gain "
    "confirmed at one-sided 5 %) ordered by held-out gain; a cause whose gain is not below the largest "
    "one's at one-sided 5 % / m (m causes compared, Bonferroni; batch means of the per-sample "
    "improvement) overlaps it, and among overlapping causes the extension with the fewest parameters wins"
)
