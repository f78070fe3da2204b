"""Why the 0 g closed loop errs more than the open loop (docs/figures.md, control bench).

The steps of tests/strain_control/test_closed_loop_emulator.py at 0 g (CI size: the estimator,
gains and static map from seed 100, the board at seed 7) on the simulator as it is and with its
recording-to-recording effects switched off one group at a time (porosense.sim.params.Variation:
per recording a sensitivity change, a contact-law scale change, a kinetics change, an R0 change
and the softening state at the start; per print the rest). The closed loop follows the
on-board estimate of the strain, whose sensor changed since the recordings it was identified
on; the open loop sets the vacuum from the static map of the same print, whose foam does not
change between recordings.

Usage: python tools/control_variation.py   (prints one line per variant, CPU seconds beside)
"""

from __future__ import annotations

import os
import time

from porosense.control.loadbench import HOLD_S, TARGETS, identify_setup, measure_load
from porosense.sim import Physics

VARIANTS = {
    "as it is": {},
    "no recording-to-recording change": {
        "record_gain_sd": 0.0,
        "record_scale_sd": 0.0,
        "record_kinetics_sd": 0.0,
        "record_r0_sd": 0.0,
    },
    "no sensitivity and contact-scale change": {"record_gain_sd": 0.0, "record_scale_sd": 0.0},
    "no contact-scale change": {"record_scale_sd": 0.0},
    "no sensitivity change": {"record_gain_sd": 0.0},
    "no softening state at the start": {"conditioning_range": (0.0, 0.0)},
}


def main() -> None:
    for name, variation in VARIANTS.items():
        c0 = time.process_time()
        physics = Physics().with_(variation=variation) if variation else None
        setup = identify_setup(50, seed=100, physics=physics)
        r = measure_load(setup, 0.0, TARGETS["small"], HOLD_S["small"], seed=7, physics=physics)
        steps = ", ".join(f"{m['target']:g}: {m['steady_error']:+.2f}" for m in r["closed_loop"])
        print(
            f"{name}: closed loop {r['closed_steady_error']:.2f} % strain ({steps}), open loop "
            f"{r['open_steady_error']:.2f} %; {time.process_time() - c0:.0f} s CPU, load {os.getloadavg()[0]:.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
