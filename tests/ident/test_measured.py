"""Real measured data: the Wiener-Hammerstein benchmark with process noise (Schoukens & Noel 2016).

Estimation on the first 5 of the 10 multisine realisations of WH_EstimationExample (41k
samples, full rate 78125 Hz), test on both signals of WH_TestDataset (multisine and swept
sine). Every model simulates each record from rest, so the first 200 samples (2.6 ms) of
each record are left out of the cost and of the test RMSE.
"""

import pytest

from porosense import ident
from porosense.data import read_table

SKIP = 200
N_RECORDS = 5
RATIO_BOUND = 1.0  # WH/linear test RMSE measured 0.94 (see the slow test); the bound: WH below linear


@pytest.fixture(scope="module")
def wh_data(shared_data):
    folder = shared_data / "wh_process_noise"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    est = read_table(folder / "WH_EstimationExample.csv")
    test = read_table(folder / "WH_TestDataset.csv")
    fs = float(est.columns["fs"][0])
    us = [est.columns[f"u_{i}"][:, None] for i in range(N_RECORDS)]
    ys = [est.columns[f"y_{i}"] for i in range(N_RECORDS)]
    tests = {"multisine": (test.columns["u_0"][:, None], test.columns["y_0"]),
             "swept sine": (test.columns["u_1"][:, None], test.columns["y_1"])}
    return us, ys, 1.0 / fs, tests


def _wh_against_linear(wh_data, n_records, bounds):
    us, ys, ts, tests = wh_data
    us, ys = us[:n_records], ys[:n_records]
    lin = ident.Linear(n_poles=6, n_zeros=5, skip=SKIP, max_nfev=40).fit(u=us, y=ys, ts=ts)
    wh = ident.WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=5, skip=SKIP, max_nfev=40,
                                 starts=1).fit(u=us, y=ys, ts=ts)
    for name, (u, y) in tests.items():
        e_lin = ident.rmse(y[SKIP:], lin.predict(u=u)[SKIP:]) * 1e3
        e_wh = ident.rmse(y[SKIP:], wh.predict(u=u)[SKIP:]) * 1e3
        print(f"{name}: test RMSE WH {e_wh:.2f} mV, linear {e_lin:.2f} mV (ratio {e_wh / e_lin:.3f})")
        assert e_wh < bounds[name] * e_lin


def test_wh_beats_linear_on_both_test_signals(wh_data):
    """CI size: 3 realisations (24k samples), 40 evaluations per refinement, one start (4 s CPU).

    Measured: WH/linear test RMSE 0.920 on the multisine and 0.839 on the swept sine with the
    Levenberg-Marquardt refinement (0.896 / 0.755 with MINPACK's, at the same estimation cost
    within 0.5 %: the swept sine, a signal class the estimation data do not hold, depends on which
    of two near-equal-cost splits between the blocks is reached). 2 realisations are not enough
    (1.17 on the swept sine).
    """
    _wh_against_linear(wh_data, 3, {"multisine": 0.97, "swept sine": 0.92})


@pytest.mark.slow
def test_wh_beats_linear_on_both_test_signals_five_records(wh_data):
    """5 realisations (41k samples), same settings (7 s CPU). Measured: WH/linear 0.933 on the
    multisine, 20.53/22.27 mV = 0.922 on the swept sine with the Levenberg-Marquardt refinement
    (0.870 / 0.609 with MINPACK's: the block split reached differs, H1 1p0z | H2 5p3z against
    1p1z | 5p2z, at the same estimation cost within 0.5 %)."""
    _wh_against_linear(wh_data, N_RECORDS, {"multisine": 0.97, "swept sine": 0.97})


@pytest.mark.slow
@pytest.mark.parametrize("process_noise", [False, True])
def test_selected_wh_validates_and_tests_better_than_linear(wh_data, process_noise):
    """Search over linear and WH at the order 6 poles / 5 zeros (CI size: 3 realisations to
    estimate, 1 to select), selection by the validation fit. The selected model validates at
    least as well as linear, and the WH model's multisine test RMSE is below linear's.

    Measured (this CI size): linear 38.64 mV, WH 36.26 mV on the test multisine (WH/linear 0.94;
    the selection keeps linear: WH validates 0.36 points better, within one standard error). The process
    noise enters before the static nonlinearity, so the output-error estimate of g is the
    noise-smoothed map: on these records a WH model estimated on the noise-free test period
    fits the estimation data worse than the linear model does (93.0 mV against 87.7 mV), and
    no output-error estimator can reach the 2x ratio that the noise-free test would allow.

    With ``process_noise`` (a Gaussian noise at g's input, its level measured from the two
    periods of each realisation, candidates scored by their expected output on the held-out
    realisation, which carries the same noise): the WH candidate is the better of the
    noise-aware and OE fits by validation fit (the noise-aware one when they are within one
    standard error), so it validates at least as well as the OE WH up to that error.
    Measured: the OE member is kept (same 36.26 mV; 50-90 s wall against 7 s): the noise-aware
    member validates more than one standard error worse, so the tie rule does not keep it; the
    measured level helps with 5 realisations (the test below).
    Without repeated periods the level is not identifiable from the mean output (a smoother g
    with less noise gives the same expected output; tests/ident/test_process_noise.py).
    The test data carry no comparable noise: a WH fitted on the multisine reaches 0.83 mV, while
    the two periods of an estimation realisation (same input to 0.2 mV) differ by 121 mV rms.
    """
    us, ys, ts, tests = wh_data
    res = ident.search(u=us[:3], y=ys[:3], ts=ts, validation=(us[3:4], ys[3:4]), validation_skip=SKIP,
                       skip=SKIP, grid=[("linear", 6, 5), ("wh", 6, 5)], criterion="fit", max_nfev=60,
                       starts=1, progress=False, process_noise=process_noise)
    per = res.best_per_structure("fit")
    u, y = tests["multisine"]
    err = {k: ident.rmse(y[SKIP:], c.model.predict(u=u)[SKIP:]) * 1e3 for k, c in per.items()}
    print(res)
    print("test RMSE (mV):", {k: round(v, 2) for k, v in err.items()}, "ratio", err["linear"] / err["wh"])
    assert res.best.validation_fit >= per["linear"].validation_fit
    assert err["wh"] < RATIO_BOUND * err["linear"]


PERIOD_NOISE_RATIO = 1.6  # linear / noise-aware WH test RMSE must exceed this (measured 1.82)


@pytest.mark.slow
def test_noise_level_from_repeated_periods_on_the_benchmark(wh_data):
    """Each estimation realisation holds two periods of its multisine, so the process noise's
    level is identified from the period differences (identify --process-noise does this when
    the input repeats) and g is learnt noise-free: the test multisine carries no such noise.

    Measured (5 realisations, 6 poles / 3 zeros, 10 breakpoints, 40 evaluations per refinement):
    noise-aware WH 20.49 mV against linear 37.32 mV (ratio 1.82; the OE WH 36.26 mV); noise level
    1.16 x the spread of g's input, period power ratio 1.00. With the default 200 evaluations
    (`porosense bench ident`): 13.91 against 37.33 mV (ratio 2.68); all 10 realisations, 200
    evaluations: 20.03 against 38.14 mV (1.90). Of the OE builds refined with the noise, the
    ones within one standard error of the lowest expected-output error are tied and the fewest
    parameters taken (the order search's rule): a BLA split each time here (3 | 3 poles with 5
    realisations, 4 | 2 from its identity start with 10). With
    the blocks of a WH fitted on the noise-free test multisine the same deconvolution reaches
    11.2 mV (tools/explore/wh_oracle_blocks.py), so what is left is in the blocks the noisy
    records give. The expected-output cost does not tell the blocks apart: the BLA split ranked
    by its noise-aware error instead (g re-solved at 0.9 x the spread) and refined the same way
    fits the records better than the selected build (0.37 % lower error with 5 realisations;
    tools/explore/wh_noise_ranked_split.py) and tests worse, 26.1 mV with 5 realisations and
    41.0 mV with 10. Every build side by side: tools/explore/wh_process_noise_builds.py.
    Bound: 1.6.
    """
    us, ys, ts, tests = wh_data
    lin = ident.Linear(n_poles=6, n_zeros=5, skip=SKIP, max_nfev=40).fit(u=us, y=ys, ts=ts)
    wh = ident.WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=10, skip=SKIP, max_nfev=40, starts=1,
                                 process_noise=True).fit(u=us, y=ys, ts=ts)
    info = wh.info["process_noise"]
    u, y = tests["multisine"]
    e_lin = ident.rmse(y[SKIP:], lin.predict(u=u)[SKIP:]) * 1e3
    e_wh = ident.rmse(y[SKIP:], wh.predict(u=u)[SKIP:]) * 1e3
    print(f"multisine: noise-aware WH {e_wh:.2f} mV, linear {e_lin:.2f} mV (ratio {e_lin / e_wh:.2f}); "
          f"noise level {info['sigma_per_spread']:.2f} x g's input spread, power ratio {info['power_ratio']:.3f}; "
          f"{info['periods']}")
    assert info["method"] == "repeated periods"
    assert e_lin / e_wh > PERIOD_NOISE_RATIO
