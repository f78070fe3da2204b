"""Where the simulator trials' misses come from (tests/diagnose/test_diagnose_sim.py).

The trials of tests/diagnose/test_diagnose_sim.py (porosense.diagnose.trials.run_sim_trial, 12
per cause and 12 clean contractor trials, seeds 1000-1011) on the simulator as it is and with the
recordings' variation and R0 drift (porosense.sim.params.PHYSICS_EFFECTS ``repeat_variation``
and ``baseline_drift``) switched off in the records, in the simulator calibrated on them
(porosense.diagnose.calibrate: the mean recording, each record with its own recording state
fitted within the simulator's stated spread), or in both.

Usage: python tools/sim_diagnosis_variation.py [VARIANT ...] [--seeds FIRST-LAST]
(prints per cause the top-1 count with what each trial named, the held-out gain of the hidden
cause's own extension per trial, the clean 3-DoF segment's count (seeds + 2000, as the test's
3000-3011), and a total per variant, CPU seconds beside; variants: as_it_is, off_in_both,
off_in_records, off_in_calibration; all of them by default. ``--seeds 1012-1023``: seeds the
test does not run, to see whether its figures hold beyond them)
"""

from __future__ import annotations

import argparse
import os
import time

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE
from porosense.sim import Physics

SEEDS = range(1000, 1012)
#: the clean 3-DoF segment's seed = the contractor's + this (tests/diagnose/test_diagnose_sim.py)
SEGMENT_OFFSET = 2000
OFF = ("repeat_variation", "baseline_drift")


def _variants() -> dict:
    off = Physics().without(*OFF)
    return {
        "as_it_is": (None, None),
        "off_in_both": (off, off),
        "off_in_records": (off, None),
        "off_in_calibration": (None, off),
    }


def main(names, seeds=SEEDS) -> None:
    variants = _variants()
    for name in names or list(variants):
        records, nominal = variants[name]
        c0 = time.process_time()
        hits = clean = 0
        for cause in list(trials.SIM_CAUSES) + [NONE]:
            runs = [trials.run_sim_trial(cause, s, records, nominal) for s in seeds]
            tops = [r.top for r in runs]
            k = sum(t == cause for t in tops)
            if cause == NONE:
                clean = k
            else:
                hits += k
            print(f"{name}: {cause} {k}/{len(seeds)} ({', '.join(tops)})", flush=True)
            if cause != NONE:  # the held-out gain of the hidden cause's own extension, points
                print(f"{name}: {cause} gains " + " ".join(f"{r.gain:+.2f}" for r in runs), flush=True)
        segment = [trials.run_sim_3dof_trial(NONE, s + SEGMENT_OFFSET, records, nominal).top for s in seeds]
        print(f"{name}: 3-DoF segment none {segment.count(NONE)}/{len(seeds)} ({', '.join(segment)})", flush=True)
        n = len(trials.SIM_CAUSES) * len(seeds)
        print(
            f"{name}: causes top-1 {hits}/{n}, clean named none {clean}/{len(seeds)}; "
            f"{time.process_time() - c0:.0f} s CPU, load {os.getloadavg()[0]:.1f}",
            flush=True,
        )


def _seeds(text: str) -> range:
    first, _, last = text.partition("-")
    return range(int(first), int(last or first) + 1)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Top-1 of the simulator diagnosis trials per cause.")
    parser.add_argument("variants", nargs="*", metavar="VARIANT", help=f"any of {', '.join(_variants())} (default all)")
    parser.add_argument("--seeds", type=_seeds, default=SEEDS, metavar="FIRST-LAST", help="default 1000-1011")
    args = parser.parse_args()
    unknown = [v for v in args.variants if v not in _variants()]
    if unknown:
        parser.error(f"unknown variant {unknown[0]} (any of {', '.join(_variants())})")
    main(args.variants, args.seeds)
