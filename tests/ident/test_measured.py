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
RATIO_BOUND = 1.0  # WH/linear test RMSE measured 0.94 (see the test); the bound: WH below linear


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


def test_wh_beats_linear_on_both_test_signals(wh_data):
    us, ys, ts, tests = wh_data
    lin = ident.Linear(n_poles=6, n_zeros=5, skip=SKIP).fit(u=us, y=ys, ts=ts)
    wh = ident.WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=5, skip=SKIP).fit(u=us, y=ys, ts=ts)
    for name, (u, y) in tests.items():
        e_lin = ident.rmse(y[SKIP:], lin.predict(u=u)[SKIP:]) * 1e3
        e_wh = ident.rmse(y[SKIP:], wh.predict(u=u)[SKIP:]) * 1e3
        print(f"{name}: test RMSE WH {e_wh:.2f} mV, linear {e_lin:.2f} mV")
        assert e_wh < e_lin


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
    """
    us, ys, ts, tests = wh_data
    res = ident.search(u=us[:3], y=ys[:3], ts=ts, validation=(us[3:4], ys[3:4]), validation_skip=SKIP,
                       skip=SKIP, grid=[("linear", 6, 5), ("wh", 6, 5)], criterion="fit", max_nfev=60,
                       starts=1, progress=False)
    per = res.best_per_structure("fit")
    u, y = tests["multisine"]
    err = {k: ident.rmse(y[SKIP:], c.model.predict(u=u)[SKIP:]) * 1e3 for k, c in per.items()}
    print(res)
    print("test RMSE (mV):", {k: round(v, 2) for k, v in err.items()}, "ratio", err["linear"] / err["wh"])
    assert res.best.validation_fit >= per["linear"].validation_fit
    assert err["wh"] < RATIO_BOUND * err["linear"]
