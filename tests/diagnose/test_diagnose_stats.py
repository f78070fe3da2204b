"""Residual statistics: false-alarm rates at their stated level, and detection of what they test."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from porosense.diagnose import signals, stats

ALPHA = 0.01
N_RUNS = 200
# binomial bound: with 200 runs at a true rate of 1 %, more than 3.5 % rejections has p < 0.5 %
MAX_RATE = 0.035


def coloured(rng, n, pole=0.9):
    return signal.lfilter([1.0], [1.0, -pole], rng.normal(size=n))


def test_autocorrelation_false_alarm_on_white_noise():
    rng = np.random.default_rng(1)
    rate = np.mean([stats.residual_autocorrelation(rng.normal(size=800), 25, ALPHA).significant for _ in range(N_RUNS)])
    assert rate <= MAX_RATE


def test_autocorrelation_detects_coloured_residual():
    rng = np.random.default_rng(2)
    assert stats.residual_autocorrelation(coloured(rng, 800, 0.5), 25, ALPHA).significant


def test_crosscorrelation_bands_hold_for_coloured_input_and_residual():
    """Both signals strongly coloured and independent: prewhitening keeps the 1 % level."""
    rng = np.random.default_rng(3)
    rate = np.mean(
        [
            stats.input_crosscorrelation(coloured(rng, 800, 0.95), coloured(rng, 800, 0.9), 25, ALPHA).significant
            for _ in range(N_RUNS)
        ]
    )
    assert rate <= MAX_RATE


def test_naive_bands_would_fail_for_coloured_signals():
    """The reason for prewhitening: 1/sqrt(N) bands on raw coloured signals reject far too often."""
    rng = np.random.default_rng(4)
    hits = 0
    for _ in range(100):
        u, e = coloured(rng, 800, 0.95), coloured(rng, 800, 0.9)
        _, r = signals.crosscorr(u, e, 25)
        hits += np.max(np.abs(r)) * np.sqrt(800) > stats._zcrit(ALPHA, 51)
    assert hits / 100 > 0.2


def test_crosscorrelation_peak_is_the_missing_delay():
    rng = np.random.default_rng(5)
    u = coloured(rng, 2000, 0.7)
    e = 0.5 * signals.shift(u, 7) + rng.normal(size=2000)
    res = stats.input_crosscorrelation(u, e, 25, ALPHA)
    assert res.significant and res.detail["peak_lag"] == 7


def test_gls_f_test_false_alarm_with_autocorrelated_residual_and_slow_regressor():
    """AR(1) residual at 0.95 and a random-walk regressor: naive OLS would reject most of the time."""
    rng = np.random.default_rng(6)
    rej = 0
    for _ in range(N_RUNS):
        e = coloured(rng, 600, 0.95)
        z = np.cumsum(rng.normal(size=600))
        rej += stats.gls_f_test(e, z[:, None]).p < ALPHA
    assert rej / N_RUNS <= MAX_RATE


def test_gls_f_test_detects_dependence():
    rng = np.random.default_rng(7)
    z = np.cumsum(rng.normal(size=600))
    z = coloured(rng, 600, 0.5)
    e = coloured(rng, 600, 0.95) + 0.5 * z
    assert stats.gls_f_test(e, z[:, None]).p < 1e-6


def test_billings_voon_quiet_for_linear_and_firing_for_nonlinear():
    rng = np.random.default_rng(8)
    u = rng.normal(size=3000)
    linear_resid = coloured(rng, 3000, 0.5)
    assert not any(t.significant for t in stats.billings_voon(u, linear_resid, 20, ALPHA).values())
    quadratic_resid = linear_resid + 0.5 * signal.lfilter([1.0], [1.0, -0.5], u * u)
    assert stats.billings_voon(u, quadratic_resid, 20, ALPHA)["u2_e"].significant


def test_spectral_line_found_and_false_alarm_controlled():
    rng = np.random.default_rng(9)
    ts = 0.05
    t = np.arange(2000) * ts
    e = coloured(rng, 2000, 0.8) + 0.6 * np.sin(2 * np.pi * 2.3 * t)
    res = stats.spectral_lines(e, ts, ALPHA)
    assert res.significant and abs(res.detail["freq_hz"] - 2.3) < 2.0 / (2000 * ts)
    rate = np.mean([stats.spectral_lines(coloured(rng, 2000, 0.8), ts, ALPHA).significant for _ in range(N_RUNS)])
    assert rate <= MAX_RATE


def test_limit_clustering_sees_clipping_not_a_smooth_signal():
    rng = np.random.default_rng(10)
    x = np.sin(np.linspace(0, 20, 2000)) + 0.05 * rng.normal(size=2000)
    assert not stats.limit_clustering(x, ALPHA).significant
    clipped = np.maximum(x, -0.7)
    res = stats.limit_clustering(clipped, ALPHA)
    assert res.significant and res.detail["side"] == "low" and res.detail["limit"] == pytest.approx(-0.7)


def test_isolated_spikes_found_and_false_alarm_controlled():
    rng = np.random.default_rng(11)
    rate = np.mean([stats.isolated_spikes(coloured(rng, 2000, 0.9), ALPHA).significant for _ in range(N_RUNS)])
    assert rate <= MAX_RATE
    e = coloured(rng, 2000, 0.9)
    e[rng.choice(2000, 8, replace=False)] += 25.0
    res = stats.isolated_spikes(e, ALPHA)
    assert res.significant and res.value >= 6


def test_ranking_never_places_a_simpler_cause_above_one_that_gains_significantly_more():
    """A (10 points, 60 parameters, a noisy improvement), B (8 points, 37 parameters) and C (2 points,
    1 parameter, B's improvement less 6 per sample: significantly below B, not below A's noisy one).
    The simplest-extension rule among gains that overlap the largest would put C first; C's gain is
    significantly below B's, so B, which overlaps A, is placed first and C after both."""
    from porosense.diagnose import ranking

    rng = np.random.default_rng(5)
    b = 8.0 + rng.normal(0.0, 1.0, 2000)
    a = b + 2.0 + rng.normal(0.0, 1000.0, 2000)
    c = b - 6.0 + rng.normal(0.0, 0.1, 2000)
    cands = [ranking.Candidate("A", 10.0, a, 60), ranking.Candidate("B", 8.0, b, 37), ranking.Candidate("C", 2.0, c, 1)]
    order, steps = ranking.rank(cands)
    assert order == ["B", "A", "C"], (order, steps[0])
    assert steps[0].overlapping == ["A", "B"] and steps[0].below_largest["C"][1] > 0.025
