"""Where the simulator trials' misses come from (tests/diagnose/test_diagnose_sim.py).

The trials of tests/diagnose/test_diagnose_sim.py (porosense.diagnose.trials.run_sim_trial, 12
per cause and 12 clean contractor trials, seeds 1000-1011) on the simulator as it is and with the
recordings' variation and R0 drift (porosense.sim.params.PHYSICS_EFFECTS ``repeat_variation``
and ``baseline_drift``) switched off in the records, in the simulator calibrated on them
(porosense.diagnose.calibrate: the mean recording, each record with its own recording state
fitted within the simulator's stated spread), or in both.

Usage: python tools/sim_diagnosis_variation.py [VARIANT ...]
(prints per cause the top-1 count with what each trial named, the held-out gain of the hidden
cause's own extension per trial, and a total per variant, CPU seconds beside; variants: as_it_is,
off_in_both, off_in_records, off_in_calibration; all of them by default)
"""

from __future__ import annotations

import os
import sys
import time

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE
from porosense.sim import Physics

SEEDS = range(1000, 1012)
OFF = ("repeat_variation", "baseline_drift")


def _variants() -> dict:
    off = Physics().without(*OFF)
    return {
        "as_it_is": (None, None),
        "off_in_both": (off, off),
        "off_in_records": (off, None),
        "off_in_calibration": (None, off),
    }


def main(names) -> None:
    variants = _variants()
    for name in names or list(variants):
        records, nominal = variants[name]
        c0 = time.process_time()
        hits = clean = 0
        for cause in list(trials.SIM_CAUSES) + [NONE]:
            runs = [trials.run_sim_trial(cause, s, records, nominal) for s in SEEDS]
            tops = [r.top for r in runs]
            k = sum(t == cause for t in tops)
            if cause == NONE:
                clean = k
            else:
                hits += k
            print(f"{name}: {cause} {k}/{len(SEEDS)} ({', '.join(tops)})", flush=True)
            if cause != NONE:  # the held-out gain of the hidden cause's own extension, points
                print(f"{name}: {cause} gains " + " ".join(f"{r.gain:+.2f}" for r in runs), flush=True)
        n = len(trials.SIM_CAUSES) * len(SEEDS)
        print(
            f"{name}: causes top-1 {hits}/{n}, clean named none {clean}/{len(SEEDS)}; "
            f"{time.process_time() - c0:.0f} s CPU, load {os.getloadavg()[0]:.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
