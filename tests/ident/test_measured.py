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
