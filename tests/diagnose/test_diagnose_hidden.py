"""Hidden effects from the independent generator (porosense.bench.hidden_effects).

The generator was written apart from the detector: its own nominal system (order 1-3, random
poles, 6-25 samples per time constant), its own effect shapes (exp/log maps, backlash and
Bouc-Wen, random-walk drift, square waves, coupling through a slow filter, ...) and wide
random strengths (hidden_effects.STRENGTHS). The harness is the bench's
(porosense.bench.diagnose): the nominal linear OE model at the trial's nominal order from
porosense.ident, u_aux and load offered as condition columns.

Seeds: these tests use 9000 onwards, the bench figure (docs/figures.md) uses BENCH_SEED onwards,
development used 7000 onwards. Bounds are the issue's: top-1 >= 90 % over all causes and
none on clean data in >= 95 % (asserted on the slow run; the quick run checks the rules that
hold for every trial).
"""

from __future__ import annotations

import os

import pytest

from porosense.bench import diagnose as bench
from porosense.bench import hidden_effects as he

TEST_SEED = 9000
IN_CI = bool(os.environ.get("CI"))


def test_gains_are_simulation_fits_against_nominal_plus_g0_on_the_same_samples():
    trial = he.draw_trial("outliers", TEST_SEED)
    d = bench.diagnose_trial(trial)
    assert d.top == "outliers"
    top = d.findings[0]
    # the outlier extension drops rejected samples: the same samples leave the baseline too,
    # and the gain is no larger than what the robust refit adds (no free points from dropping)
    assert "left out of both" in top.evidence
    others = [f for f in d.findings if f.cause not in ("outliers", "none")]
    base = others[0].fit_before
    assert all(abs(f.fit_before - base) < 1e-9 for f in others)
    assert abs(top.gain) < 2.0, top.gain
    # drift and periodic extensions report their one-step predictor figure separately
    assert d.finding("drift").predictor_gain is not None
    assert d.finding("static_nonlinearity").predictor_gain is None


def test_evidence_names_statistic_value_noise_ratio_and_device_note():
    d = bench.diagnose_trial(he.draw_trial("periodic_disturbance", TEST_SEED))
    for f in d.findings:
        assert f.statistic.split(" = ")[0] in f.evidence
        value = f.statistic.split(" = ")[1] if " = " in f.statistic else ""
        assert value and any(ch.isdigit() for ch in value)
        if f.cause != "none":
            assert "x the residual's noise" in f.evidence and f.on_device
    keys = set(d.to_dict()["findings"][0])
    assert {"cause", "confidence", "statistic", "evidence", "extension", "fit_before", "fit_after", "gain"} <= keys
    confidences = [f.confidence for f in d.findings]
    assert all(0 <= c <= 1 for c in confidences)
    found = [f for f in d.findings if f.significant]
    assert [f.cause for f in d.findings[: len(found)]] == [f.cause for f in found]


@pytest.mark.parametrize("kind", he.FALSE_ALARM_KINDS)
def test_clean_data_is_none(kind):
    d = bench.diagnose_trial(he.draw_trial(kind, TEST_SEED))
    assert d.top in ("none",), [(f.cause, f.strength) for f in d.findings[:3]]


def test_quantised_clean_data_is_not_outliers():
    tops = [bench.diagnose_trial(he.draw_trial("clean_quantised", TEST_SEED + k)).top for k in range(3)]
    assert "outliers" not in tops, tops


@pytest.mark.slow
def test_top1_and_false_alarm_rates_on_the_independent_generator():
    res = bench.run("small" if IN_CI else "full", seed=TEST_SEED)
    print("\n".join(res["summary"]))
    assert res["top1_overall"] >= 0.9
    assert res["false_alarm_rate"] <= 0.05
