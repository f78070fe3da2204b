"""The ranking rule: held-out gain first, and the simplest extension among gains that overlap.

Every found cause has a held-out gain confirmed against its own baseline (see :mod:`.engine`).
The ranking compares them over one common reference: the per-sample improvement on the
validation records d_c[k] = (y - nominal)^2 - (y - extension)^2 (a disturbance's predictor over
its own baseline), since the dynamics causes' gains are against the nominal model and the
others' against nominal + G0 and the adequate-order correction. The found causes are ordered by
repeating:

1. every remaining candidate is compared with every other (batch means of d_a - d_b,
   :func:`.stats.mean_positive_test`, one-sided at 5 % / (m - 1), m candidates remaining,
   Bonferroni); a candidate whose improvement is below another's is *dominated*;
2. the reference is the candidate with the largest gain as reported (fit points against its own
   baseline: the nominal for the dynamics causes, the corrected model for the others); it is
   not itself tested for dominance, and the other candidates that are not dominated overlap it;
3. among the overlapping candidates the one with the fewest parameters wins (then the larger
   gain, then the name); it is placed next and removed.

So a cause is placed above one with a larger gain only when the two gains overlap and its
extension is simpler, and never above a cause whose gain is significantly larger than its own.
Causes that are not found (no significant test, evidence that disagrees with the name, or no
confirmed gain) come after ``none``, by gain, so a cause whose extension does not gain is never
ranked above one that does.

Disturbances (drift, periodic_disturbance, outliers) are ranked after the input-output causes,
among themselves by the same rule: their gain is a one-step predictor's (the extension reads the
measured output: drift and periodic_disturbance track whatever slow misfit the corrected model
leaves, whatever its cause; outliers filters glitches out of it), not a simulation's. On the
tensile records of tests/sim/test_diagnose_material.py (seed 1) the drift predictor gains +23.3 points on records read through a clip and +0.7 on the same records
read in full: its gain there is the clip's misfit tracked, so it is no evidence against an
input-output cause and the two scales are not compared. A found disturbance with a larger
gain than the top input-output cause is reported as such (``why_top``).
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
    """(causes in rank order, one :class:`Step` per placed cause) for the found ``candidates``.

    Parameters
    ----------
    candidates : list of Candidate
        Found causes: gain (fit points), per-sample improvement on validation (output units
        squared), parameter count.

    Returns
    -------
    tuple of (list of str, list of Step)
        Causes in rank order, and why each was placed.
    """
    remaining = list(candidates)
    order, steps = [], []
    while remaining:
        best = max(remaining, key=lambda c: (c.gain, -c.n_params, c.cause))
        m = len(remaining) - 1
        tests = {c.cause: _below(best, c, m) for c in remaining if c is not best}
        # a candidate below any other remaining one (not only the largest) does not overlap: a
        # simpler extension never passes one whose gain is significantly larger than its own
        dominated = {
            c.cause
            for c in remaining
            if c is not best
            and (
                tests[c.cause].confirmed
                or any(_below(o, c, m).confirmed for o in remaining if o is not c and o is not best)
            )
        }
        overlap = [best] + [c for c in remaining if c is not best and c.cause not in dominated]
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
    "confirmed at one-sided 5 %) ordered by held-out gain; a cause whose improvement is not below that of "
    "the largest gain nor of any other remaining cause at one-sided 5 % / (m - 1) (m causes remaining, "
    "Bonferroni; batch means of the per-sample improvement) overlaps it, and among overlapping causes the "
    "extension with the fewest parameters wins; disturbances (drift, periodic_disturbance, outliers), whose gain "
    "is a one-step predictor's reading the measured output, are ranked after the "
    "input-output causes (a simulation's gain), among themselves by the same rule"
)
