"""Hidden effects in the actuator simulator: porosense.sim effects, diagnosed against the
simulator calibrated on the estimation experiments (the ``--sim`` path).

Strength ranges: porosense.diagnose.trials.SIM_STRENGTHS. Only the causes for which the
calibrated-simulation diagnosis meets the bound are asserted here; the measured rates of the
others are reported by the benchmark (see the module docstring of porosense.bench.diagnose).
"""

from __future__ import annotations

import os

import pytest

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE

ASSERTED = ["time_delay", "periodic_disturbance", "saturation", "outliers", "static_nonlinearity",
            "hysteresis", NONE]
IN_CI = bool(os.environ.get("CI"))


def _check(cause, n, seed):
    results = [trials.run_sim_trial(cause, seed + k) for k in range(n)]
    tops = [r.top for r in results]
    rate = sum(t == cause for t in tops) / n
    assert rate >= 0.9, f"{cause}: top-1 in {rate:.0%} of {n} simulator trials ({tops})"
    if cause != NONE:
        assert all(r.gain > 0 for r in results if r.top == cause)


@pytest.mark.parametrize("cause", ASSERTED)
def test_sim_hidden_cause_found_quick(cause):
    _check(cause, 1, 3000)


@pytest.mark.slow
@pytest.mark.parametrize("cause", ASSERTED)
def test_sim_hidden_cause_found_many_trials(cause):
    _check(cause, 4 if IN_CI else 20, 1000)
