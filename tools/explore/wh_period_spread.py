"""Between-period spread of the measured WH process-noise benchmark's estimation records.

Each realisation of WH_EstimationExample holds two periods of one multisine: the inputs of the two
periods agree to the generator's precision while the outputs differ by the process noise (it
enters before the static nonlinearity). Prints, per realisation, the RMS of the input and output
differences between the periods (mV). Run: .venv/bin/python tools/explore/wh_period_spread.py
(reads ../shared/data/wh_process_noise, or POROSENSE_SHARED_DATA).
"""

import sys

import numpy as np
from wh_benchmark import tables

PERIOD = 4096


def main() -> int:
    est, _ = tables()
    for i in range(10):
        u, y = est.columns[f"u_{i}"], est.columns[f"y_{i}"]
        du = u[PERIOD : 2 * PERIOD] - u[:PERIOD]
        dy = y[PERIOD : 2 * PERIOD] - y[:PERIOD]
        print(
            f"realisation {i}: input difference {np.std(du) * 1e3:.2f} mV rms, "
            f"output difference {np.std(dy) * 1e3:.1f} mV rms (output {np.std(y) * 1e3:.0f} mV rms)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
