"""Identification on an independent resistive strain-sensor generator (sensor_generator.py: play
hysteresis, a saturating exponential map, two-time-constant relaxation, drift, noise; no model
structure is exact), the way a researcher meets it: one record of 3,400 samples at 8.6 Hz,
strain estimated from dR, the first 60 % to identify and the last 40 % to test.

The order search runs as ``porosense identify`` does without --validation on one file: the
last 25 % of the identification part held out for selection (criterion fit, staged search).
The question is the issue's: does the selected model (all structures) test at least as well as
the linear model the same rule selects among the linear candidates?

Measured over seeds 0-20 (``SENSOR_SEEDS=0-20 pytest tests/ident/test_sensor_generator.py -m slow
-s``; the suite runs seeds 0-5 as two tests of 3 seeds, so that each stays short and the two run
side by side): the selection tested at or above the linear selection in 20 of 21 seeds and more
than a point above it in 18, by a median of 16.6 points; the exception (seed 5) validated at
79.7 % on a hold-out window whose strain range (5-24 %) and history differ from the test part,
and tested at 41.8 % against linear 68.6 %. One window is what a single file offers to select on.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from sensor_generator import sensor_record

from porosense import ident

FS = 8.6  # Hz
EST_FRACTION, HOLDOUT_FRACTION = 0.6, 0.25
TOLERANCE = 1.0  # fit points: a selection this close to linear is a tie, not a loss


def _seed_groups():
    """The seeds in groups of 3 (SENSOR_SEEDS, default 0-5: two groups)."""
    spec = os.environ.get("SENSOR_SEEDS", "0-5")
    lo, hi = (int(v) for v in spec.split("-"))
    seeds = list(range(lo, hi + 1))
    return [seeds[k : k + 3] for k in range(0, len(seeds), 3)]


def _study(seed: int) -> dict:
    rec = sensor_record(seed, fs=FS)
    n = len(rec.t)
    n_est = int(EST_FRACTION * n)
    cut = int((1 - HOLDOUT_FRACTION) * n_est)
    u, y = rec.dR[:, None] / 100, rec.strain
    res = ident.search(
        u=[u[:cut]],
        y=[y[:cut]],
        ts=1 / FS,
        validation=([u[:n_est]], [y[:n_est]]),
        validation_skip=[cut],
        criterion="fit",
        staged=True,
        max_nfev=200,
        progress=False,
    )
    linear = ident.SearchResult(
        [c for c in res.candidates if c.structure == "linear"], res.seconds, res.tie_tol, res.criterion
    ).best

    def test_fit(model) -> float:
        return ident.fit_percent(y[n_est:], model.predict(u=u)[n_est:])

    best = res.best
    return {
        "seed": seed,
        "selected": f"{best.structure} {best.n_poles}p{best.n_zeros}z",
        "test": test_fit(best.model),
        "linear": f"{linear.n_poles}p{linear.n_zeros}z",
        "linear_test": test_fit(linear.model),
        "validation": best.validation_fit,
        "linear_validation": linear.validation_fit,
    }


@pytest.mark.slow
@pytest.mark.parametrize("seeds", _seed_groups(), ids=lambda g: f"seeds {g[0]}-{g[-1]}")
def test_the_selection_tests_at_least_as_well_as_linear_on_an_independent_sensor(seeds):
    rows = [_study(s) for s in seeds]
    for r in rows:
        print(
            f"seed {r['seed']}: selected {r['selected']} validation {r['validation']:.1f} % test {r['test']:.1f} % | "
            f"linear {r['linear']} validation {r['linear_validation']:.1f} % test {r['linear_test']:.1f} %"
        )
    losses = [r for r in rows if r["test"] < r["linear_test"] - TOLERANCE]
    gains = np.array([r["test"] - r["linear_test"] for r in rows])
    print(
        f"selection at or above linear in {len(rows) - len(losses)} of {len(rows)} seeds, above it in "
        f"{int(np.sum(gains > TOLERANCE))}; median gain {np.median(gains):.1f} points"
    )
    # 1 loss in 21 seeds measured; at that rate 2 or more losses in 3 seeds happen with
    # probability 0.7 %, so a second loss in a group means the engine got worse.
    assert len(losses) <= 1, losses
    # The nonlinear structures earn their place: above linear in 18 of 21 seeds measured (4 of the
    # 6 run here). At that rate a group of 3 with none above linear has probability 0.3 % (the
    # whole 6 with fewer than 3, the bound before the groups: 0.5 %).
    assert np.sum(gains > TOLERANCE) >= 1
