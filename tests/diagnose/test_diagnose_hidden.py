"""Hidden effects from the independent generator (porosense.bench.hidden_effects).

The generator was written apart from the detector: its own nominal system (order 1-3, random
poles, 6-25 samples per time constant), its own effect shapes (exp/log maps, backlash and
Bouc-Wen, random-walk drift, square waves, coupling through a slow filter, ...) and wide
random strengths (hidden_effects.STRENGTHS). The harness is the bench's
(porosense.bench.diagnose): the nominal linear OE model at the trial's nominal order from
porosense.ident, u_aux and load offered as condition columns.

Seeds: these tests use 9000 onwards, the bench figure (docs/figures.md) uses BENCH_SEED onwards,
development used 7000 onwards. The rates are checked at one size everywhere (CI or not):
TRIALS_PER_CAUSE trials of each of the 11 causes and TRIALS_PER_CLEAN of each of the 3 clean
kinds (module constants; the bounds they support are in the slow test's docstring).
"""

from __future__ import annotations

import functools

import pytest
from scipy.stats import beta

from porosense.bench import diagnose as bench
from porosense.bench import hidden_effects as he
from porosense.diagnose import dynamics

TEST_SEED = 9000
TRIALS_PER_CAUSE = 6
TRIALS_PER_CLEAN = 10


def test_gains_are_held_out_fits_against_the_stated_baseline_on_the_same_samples():
    d = bench.diagnose_trial(he.draw_trial("outliers", TEST_SEED))
    assert d.top == "outliers"
    top = d.findings[0]
    # the outlier extension drops rejected samples: the same samples leave the baseline too
    assert "left out of both" in top.evidence and top.confirmed
    # every cause outside the dynamics group is judged against the same corrected model
    others = [f for f in d.findings if f.baseline == "adequate" and f.cause not in ("outliers", "none")]
    assert others and all(abs(f.fit_before - others[0].fit_before) < 1e-9 for f in others)
    assert abs(others[0].fit_before - d.corrected.fit) < 1e-9
    # the dynamics group against the nominal model, whose fit is printed first
    for cause in ("unmodelled_dynamics", "time_delay", "slow_relaxation"):
        assert d.finding(cause).baseline == "nominal"
        assert abs(d.finding(cause).fit_before - d.nominal.fit) < 1e-9
    # drift and periodic extensions are one-step predictors, and say so
    assert d.finding("drift").predictor_gain is not None
    assert d.finding("static_nonlinearity").predictor_gain is None


def test_evidence_names_statistic_value_baseline_and_why_the_top_won():
    d = bench.diagnose_trial(he.draw_trial("periodic_disturbance", TEST_SEED))
    assert d.top == "periodic_disturbance" and d.why_top
    for f in d.findings:
        assert f.statistic.split(" = ")[0] in f.evidence
        value = f.statistic.split(" = ")[1] if " = " in f.statistic else ""
        assert value and any(ch.isdigit() for ch in value)
        if f.cause != "none":
            assert "x the residual's noise" in f.evidence and f.on_device
    doc = d.to_dict()
    assert {"nominal", "corrected", "dynamics", "why_top", "ranking_rule", "baselines"} <= set(doc)
    assert set(doc["findings"][0]) == set(type(d.findings[0]).KEYS)
    assert all(0 <= f.confidence <= 1 for f in d.findings)
    # found causes first, then none, then the rest by gain
    found = [f.cause for f in d.findings if f.found]
    assert [f.cause for f in d.findings[: len(found)]] == found
    rest = list(d.findings[len(found) + 1 :])
    assert all(a.gain >= b.gain for a, b in zip(rest, rest[1:]))


def test_a_relaxation_is_a_slow_pole_and_a_missing_pole_is_not():
    """The pole a linear model of the measured output needs beyond the nominal's: for a hidden
    relaxation (8-40x slower than the dominant pole) beyond twice the nominal's slowest time
    constant at one-sided 5 %, so slow_relaxation explains the linear deficit and
    unmodelled_dynamics is not named; for hidden extra poles (1.5-6x faster) below it at
    one-sided 5 %. Measured: seed 9000's relaxation at 27.5 s against the nominal's 1.19 s; the
    extra poles of seeds 9000-9002 leave the slowest at 1.38, 0.82 and 0.353 s against the
    nominal's 2.25, 1.09 and 0.448 s."""
    d = bench.diagnose_trial(he.draw_trial("slow_relaxation", TEST_SEED))
    assert d.top == "slow_relaxation"
    assert (
        "time constant" in d.finding("slow_relaxation").evidence and "(slow:" in d.finding("slow_relaxation").evidence
    )
    assert not d.finding("unmodelled_dynamics").found
    for seed in range(TEST_SEED, TEST_SEED + 3):
        trial = he.draw_trial("unmodelled_dynamics", seed)
        est = trial.estimation
        model, _ = bench.fit_nominal(est["u"], est["y"], trial.ts, trial.nominal_order)
        tau_nom = bench._slowest_tau_samples(model) * trial.ts
        pole = dynamics.slow_pole([est["u"][:, None]], [est["y"]], trial.nominal_order, tau_nom, 10 * tau_nom, trial.ts)
        assert pole.not_slow, (seed, pole.sentence())


@pytest.mark.parametrize("kind", he.FALSE_ALARM_KINDS)
def test_clean_data_is_none(kind):
    d = bench.diagnose_trial(he.draw_trial(kind, TEST_SEED))
    assert d.top == "none", [(f.cause, f.gain, f.rejected) for f in d.findings[:3]]


def test_quantised_clean_data_is_not_outliers():
    tops = [bench.diagnose_trial(he.draw_trial("clean_quantised", TEST_SEED + k)).top for k in range(3)]
    assert "outliers" not in tops, tops


def _lower_bound(k: int, n: int, level: float = 0.95) -> float:
    """One-sided Clopper-Pearson lower confidence bound of a binomial rate (k successes of n)."""
    return 0.0 if k == 0 else float(beta.ppf(1.0 - level, k, n - k + 1))


@functools.lru_cache(maxsize=1)
def _rates() -> tuple:
    """(cause trials, correct, clean trials, named none) at TEST_SEED, computed once per worker."""
    causes = bench.run_counts(TRIALS_PER_CAUSE, seed=TEST_SEED, kinds=he.CAUSES)
    clean = bench.run_counts(TRIALS_PER_CLEAN, seed=TEST_SEED, kinds=he.FALSE_ALARM_KINDS)
    print("\n".join(causes["summary"] + clean["summary"]))
    n, k = causes["trials"], causes["correct"]
    n0, k0 = clean["trials"], clean["correct"]
    print(
        f"top-1 {k}/{n} (one-sided 95 % lower bound {100 * _lower_bound(k, n):.1f} %); "
        f"clean named none {k0}/{n0} (lower bound {100 * _lower_bound(k0, n0):.1f} %)"
    )
    return n, k, n0, k0


@pytest.mark.slow
@pytest.mark.xdist_group("hidden_rates")
def test_false_alarm_and_top1_floor_on_the_independent_generator():
    """Clean data (the issue's bound): none in >= 95 % of the 30 clean trials (at most 1 false
    alarm; with 0 of 30 the one-sided 95 % upper bound of the false-alarm rate is 9.5 %).
    Measured: 30 of 30. Top-1 floor: 80 % of the 66 cause trials, a regression guard below the
    issue's 90 % (see the next test)."""
    n, k, n0, k0 = _rates()
    assert k0 / n0 >= 0.95
    assert k / n >= 0.8


@pytest.mark.slow
@pytest.mark.xdist_group("hidden_rates")
def test_top1_meets_the_issue_bound_on_the_independent_generator():
    """The issue's bound: top-1 >= 90 % over the 66 cause trials (at most 6 misses). Measured: 61
    of 66 (92.4 %, one-sided 95 % Clopper-Pearson lower bound 84.7 %; 60 of 66 before a found
    relaxation had to be a slow missing pole and then explained the linear deficit, 56 before a
    delay had to be preferred to one more pole on held-out data, cross-coupling to be additive
    and hysteresis to survive a slow trend in time). Misses: two delays the data cannot tell
    from one more pole named unmodelled_dynamics, a load dependence whose extension extrapolates
    badly to a load the estimation record lacks named drift, and a static map and a clip whose
    held-out gains are not confirmed named none. On the development seeds 7000-7009: 102 of 110
    (92.7 %; 100 before); on the bench's seeds 93 of 110 (84.5 %; 91 before, slow_relaxation 8
    of 10, was 6, docs/figures.md): 256 of 286 over the three sets (89.5 %; 251 before)."""
    n, k, _, _ = _rates()
    assert k / n >= 0.9
