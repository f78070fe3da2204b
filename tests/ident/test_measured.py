"""Real measured data: the Wiener-Hammerstein benchmark with process noise (Schoukens & Noel 2016).

Estimation on the first 5 of the 10 multisine realisations of WH_EstimationExample (41k
samples, full rate 78125 Hz), test on both signals of WH_TestDataset (multisine and swept
sine). Every model simulates each record from rest, so the first 200 samples (2.6 ms) of
each record are left out of the cost and of the test RMSE.
"""

import os

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
    tests = {
        "multisine": (test.columns["u_0"][:, None], test.columns["y_0"]),
        "swept sine": (test.columns["u_1"][:, None], test.columns["y_1"]),
    }
    return us, ys, 1.0 / fs, tests


def _wh_against_linear(wh_data, n_records, bounds):
    us, ys, ts, tests = wh_data
    us, ys = us[:n_records], ys[:n_records]
    lin = ident.Linear(n_poles=6, n_zeros=5, skip=SKIP, max_nfev=40).fit(u=us, y=ys, ts=ts)
    wh = ident.WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=5, skip=SKIP, max_nfev=40, starts=1).fit(
        u=us, y=ys, ts=ts
    )
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
def test_selected_wh_validates_and_tests_better_than_linear(wh_data):
    """Search over linear and WH at the order 6 poles / 5 zeros (CI size: 3 realisations to
    estimate, 1 to select), selection by the validation fit. The selected model validates at
    least as well as linear, and the WH model's multisine test RMSE is below linear's.

    Measured (this CI size): linear 38.64 mV, WH 36.26 mV on the test multisine (WH/linear 0.94;
    the selection keeps linear: WH validates 0.36 points better, within one standard error). The process
    noise enters before the static nonlinearity, so the output-error estimate of g is the
    noise-smoothed map: on these records a WH model estimated on the noise-free test period
    fits the estimation data worse than the linear model does (93.0 mV against 87.7 mV), and
    no output-error estimator can reach the 2x ratio that the noise-free test would allow.

    With process noise the search ranks orders by the nonparametric BLA when the records hold
    at least 4 realisations (the test below); these 3 do not.
    Without repeated periods the level is not identifiable from the mean output (a smoother g
    with less noise gives the same expected output; tests/ident/test_process_noise.py).
    The test data carry no comparable noise: a WH fitted on the multisine reaches 0.83 mV, while
    the two periods of an estimation realisation (same input to 0.2 mV) differ by 121 mV rms.
    """
    us, ys, ts, tests = wh_data
    res = ident.search(
        u=us[:3],
        y=ys[:3],
        ts=ts,
        validation=(us[3:4], ys[3:4]),
        validation_skip=SKIP,
        skip=SKIP,
        grid=[("linear", 6, 5), ("wh", 6, 5)],
        criterion="fit",
        max_nfev=60,
        starts=1,
        progress=False,
    )
    per = res.best_per_structure("fit")
    u, y = tests["multisine"]
    err = {k: ident.rmse(y[SKIP:], c.model.predict(u=u)[SKIP:]) * 1e3 for k, c in per.items()}
    print(res)
    print("test RMSE (mV):", {k: round(v, 2) for k, v in err.items()}, "ratio", err["linear"] / err["wh"])
    assert res.best.validation_fit >= per["linear"].validation_fit
    assert err["wh"] < RATIO_BOUND * err["linear"]


SEARCH_RATIO = 2.0  # the goal: linear / selected WH test RMSE
SAFE_RATIO = 1.0  # on the other five realisations: never a WH that tests worse than linear


# The search below costs 193-239 s of wall time alone on 2 cores and 517 s beside the rest of
# the suite in CI: it runs on request (WH_PROCESS_NOISE_SEARCH=1) and in
# ``porosense bench ident --only measured``, which prints the same figures.
LONG_SEARCH = os.environ.get("WH_PROCESS_NOISE_SEARCH") == "1"


@pytest.mark.slow
@pytest.mark.skipif(
    not LONG_SEARCH,
    reason="a search of 3-9 minutes: WH_PROCESS_NOISE_SEARCH=1 runs it, 'porosense bench ident --only measured' "
    "prints its figures",
)
@pytest.mark.parametrize(
    "first, bound",
    [
        (0, SEARCH_RATIO),
        pytest.param(
            5,
            SAFE_RATIO,
            marks=pytest.mark.skipif(
                os.environ.get("WH_SECOND_HALF") != "1",
                reason="the second half costs 4-9 minutes; WH_SECOND_HALF=1 runs it",
            ),
        ),
    ],
    ids=["realisations 0-4", "realisations 5-9"],
)
def test_default_search_with_process_noise_selects_a_wh_twice_better_than_linear(shared_data, first, bound):
    """The staged search of ``identify --process-noise`` over linear and WH (the paper's grid),
    5 realisations to estimate, the next to validate, on both disjoint halves of the 10. The
    records repeat their multisine, so the orders are ranked by the nonparametric BLA and its
    variance over the realisations (the validation data carry the process noise and rank
    nothing: every candidate validates within one standard error), the nonlinear structure is
    fitted at the BLA order and refitted with the process noise measured from the period
    differences, kept by the one-standard-error rule when the records determine the noise-free
    system it deconvolves (estimate.deconvolution_spread), else its output-error fit stays.
    Each structure's model is the one the search's rule selects among that structure's
    candidates (``identify --structure wh`` and ``--structure linear``).

    The grid's 6-pole orders only and 100 evaluations per refinement; ``WH_PROCESS_NOISE_SEARCH=1``
    runs realisations 0-4 (``WH_SECOND_HALF=1`` adds 5-9: both took 8-9 minutes each beside the rest
    of the suite on 2 cores). Measured at this
    size (2 cores, alone): realisations 0-4: BLA order 6p5z, WH 6p5z with process noise (the
    BLA split's identity start) 14.37 mV against linear 37.33 mV, ratio 2.60, 193 s;
    realisations 5-9: BLA order 6p3z, the deconvolution undetermined, the output-error WH 35.38
    mV against linear 39.13 mV, ratio 1.11, 239 s. Bounds: the issue's 2 on 0-4; on 5-9 no WH
    worse than linear (before the deconvolution check, the noise-aware WH of 5-9 at 6p5z tested
    at 65.7 mV).

    The whole default grid (10 breakpoints, 2 starts, 200 evaluations;
    ``porosense bench ident --only whsearch --structures wh``, or ``--realisations 5-9``): 0-4: BLA
    order 6p5z, WH with process noise 16.60 mV, ratio 2.25, 399 s; 5-9: BLA order 4p3z, the
    deconvolution undetermined, the output-error WH 35.39 mV, 472 s. With all four structures
    the rule selects linear on 0-4: the WH validates below it (within one standard error, and a
    nonlinear model validating below linear is never selected).

    How fragile the gain is: it needs a 6-pole order and the circuit's 3 | 3 split, which these
    records barely determine (on 5-9 the BLA split at 6p3z goes 2 | 4 and tests at 27.9 mV, at
    6p5z 1 | 5; ``porosense bench ident --only builds --realisations 5-9 --order 6,5 --starts 2``), and the BLA does not
    separate 4 or 5 from 6 poles beyond doubt (9 realisations select 5p4z).
    """
    folder = shared_data / "wh_process_noise"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    est = read_table(folder / "WH_EstimationExample.csv")
    test = read_table(folder / "WH_TestDataset.csv")
    which = list(range(first, first + N_RECORDS)) + [(first + N_RECORDS) % 10]  # the next one validates
    us = [est.columns[f"u_{i}"][:, None] for i in which]
    ys = [est.columns[f"y_{i}"] for i in which]
    ts = 1.0 / float(est.columns["fs"][0])
    res = ident.search(
        u=us[:N_RECORDS],
        y=ys[:N_RECORDS],
        ts=ts,
        validation=(us[N_RECORDS:], ys[N_RECORDS:]),
        validation_skip=SKIP,
        skip=SKIP,
        structures=("linear", "wh"),
        poles=(6,),
        n_breakpoints=10,
        starts=2,
        max_nfev=100,
        criterion="fit",
        staged=True,
        process_noise=True,
        progress=False,
    )
    print(res)
    u, y = test.columns["u_0"][:, None], test.columns["y_0"]
    chosen, err = {}, {}
    for s in ("linear", "wh"):
        own = ident.SearchResult(
            [c for c in res.candidates if c.structure == s], res.seconds, res.tie_tol, res.criterion
        )
        chosen[s] = own.best
        err[s] = ident.rmse(y[SKIP:], own.model.predict(u=u)[SKIP:]) * 1e3
    w = chosen["wh"]
    print(
        f"selected WH {w.n_poles}p{w.n_zeros}z ({w.model.info.get('build')}): {err['wh']:.2f} mV; selected linear "
        f"{chosen['linear'].n_poles}p{chosen['linear'].n_zeros}z: {err['linear']:.2f} mV; ratio "
        f"{err['linear'] / err['wh']:.2f}; {res.seconds:.0f} s"
    )
    assert "order from the nonparametric BLA of 5 realisations" in res.rule
    assert "process noise fitted for wh" in res.rule
    if first == 0:  # the 2x needs the noise model; elsewhere the records may leave the deconvolution
        # undetermined, and the output-error fit stays (estimate.deconvolution_spread)
        assert w.model.info["process_noise"]["method"] == "repeated periods"
    assert err["linear"] / err["wh"] >= bound
