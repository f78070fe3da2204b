"""How detectable each hidden simulator effect of the diagnosis trials is at all.

For the contractor trials of tests/diagnose/test_diagnose_sim.py (porosense.diagnose.trials,
seeds 1000-1011), the oracle is the simulator given the hidden effect with its true parameters,
calibrated on the estimation records as the nominal is (porosense.diagnose.calibrate: porosity,
scale, offset, each record's recording state). Its held-out gain is its fit on the validation
records against the nominal's, each with the record's own state fitted, and it is confirmed by the
same paired test the diagnosis uses (porosense.diagnose.stats.paired_gain_test, one-sided 5 %).
A trial whose oracle gain is not confirmed cannot be diagnosed with a confirmed gain either: the
count of confirmed oracles bounds what any diagnosis can reach at that strength range.

Only causes that are simulator effects and repeat with the record's realisation are measured
(drift, time_delay, load_dependence, slow_relaxation); the static map and the memory act on the
measured dR, a periodic disturbance's phase and outliers' glitches are drawn anew, and the
calibration leaves clipped samples out (saturation's gain is where they are).

Usage: python tools/sim_diagnosis_oracle.py [CAUSE ...]   (one line per trial, a total per cause)
"""

from __future__ import annotations

import sys

import numpy as np

from porosense.diagnose import stats, trials
from porosense.diagnose.calibrate import calibrate
from porosense.dsp.metrics import fit_percent

SEEDS = range(1000, 1012)
CAUSES = ("drift", "time_delay", "load_dependence", "slow_relaxation")


def oracle(cause: str, seed: int) -> tuple[float, object]:
    """(held-out fit gain of the true effect over the nominal, points; its paired gain test)."""
    ts = 1.0 / trials.SIM_RATE_HZ
    effects, est, val = trials.sim_trial_records(cause, seed)
    us, ys = [p for p, _, _ in est], [y for _, y, _ in est]
    nominal = calibrate("contractor", "dR_0", us, ys, ts)
    extended = calibrate("contractor", "dR_0", us, ys, ts, effects=effects)
    # the validation records concatenated, as the diagnosis scores them
    y = np.concatenate([y for _, y, _ in val])
    base = np.concatenate([nominal.predict_record(p, y, ts)[0] for p, y, _ in val])
    ext = np.concatenate([extended.predict_record(p, y, ts)[0] for p, y, _ in val])
    return fit_percent(y, ext) - fit_percent(y, base), stats.paired_gain_test(y, base, ext)


def main(causes) -> None:
    for cause in causes or CAUSES:
        confirmed = 0
        for seed in SEEDS:
            gain, test = oracle(cause, seed)
            confirmed += bool(test.confirmed)
            print(f"{cause} {seed}: oracle gain {gain:+.2f} points, t = {test.t:.2f}, p = {test.p:.3g}", flush=True)
        print(f"{cause}: oracle confirmed in {confirmed}/{len(SEEDS)} trials", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
