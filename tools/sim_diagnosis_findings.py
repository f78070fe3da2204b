"""What diagnosis says of the hidden cause in each simulator trial of tests/diagnose/test_diagnose_sim.py.

For the trials of porosense.diagnose.trials.run_sim_trial (cross_coupling in the 3-DoF
segment), one line per seed: what was named first, and the hidden cause's own
finding: its test statistic, whether it is significant, its held-out gain (fit points) with the
paired test's t and one-sided p, whether that gain is confirmed, and why it was not found. For
``none`` the line gives the strongest test instead.

Usage: python tools/sim_diagnosis_findings.py CAUSE [FIRST_SEED LAST_SEED]   (default 1000 1011)
"""

from __future__ import annotations

import sys

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE


def main(argv) -> None:
    cause = argv[0]
    lo, hi = (int(argv[1]), int(argv[2])) if len(argv) > 2 else (1000, 1011)
    for seed in range(lo, hi + 1):
        trial = trials.run_sim_trial(cause, seed)
        d = trial.diagnosis
        f = d.finding(cause)
        line = f"{cause} {seed}: named {trial.top}; {f.statistic}"
        if cause != NONE:
            line += (
                f", significant {f.significant}; gain {f.gain:+.2f} points (t {f.gain_t:.2f}, p {f.gain_p:.3g}), "
                f"confirmed {f.confirmed}" + (f"; not found: {f.rejected}" if f.rejected else "")
            )
        print(line, flush=True)


if __name__ == "__main__":
    if not sys.argv[1:] or sys.argv[1] not in trials.SIM_CAUSES + (NONE,):
        sys.exit(
            f"usage: python tools/sim_diagnosis_findings.py CAUSE [FIRST_SEED LAST_SEED]; CAUSE one of "
            f"{', '.join(trials.SIM_CAUSES + (NONE,))}"
        )
    main(sys.argv[1:])
