"""The noise-aware WH of ``identify --process-noise`` at several orders of the measured WH benchmark.

Per order (total poles, zeros; the builds choose the split): the noise-free multisine test RMSE
(mV), the validation fit on the next realisation (%, expected output), the build kept, the
level (x the spread of g's input), the simulated / measured period power with its standard
error and whether it is consistent, and the fitted noise shape per band (dB). Estimation on
the first N realisations (default 5), 10 breakpoints, 2 starts, 200 evaluations.
Run: .venv/bin/python tools/explore/wh_noise_orders.py [N] [poles,zeros ...] (default 4,1 5,2 6,3 6,5 7,4 8,3)
"""

import sys
import time

import numpy as np
from wh_benchmark import records

from porosense import ident
from porosense.ident.models import make_model

SKIP = 200
FS = 78125.0  # Hz


def main() -> int:
    args = sys.argv[1:]
    n = int(args[0]) if args and "," not in args[0] else 5
    orders = [tuple(map(int, a.split(","))) for a in args if "," in a] or [
        (4, 1),
        (5, 2),
        (6, 3),
        (6, 5),
        (7, 4),
        (8, 3),
    ]
    us, ys, ut, yt = records(n + 1)
    for p, z in orders:
        t0 = time.perf_counter()
        m = make_model(
            "wh", n_poles=p, n_zeros=z, n_breakpoints=10, starts=2, max_nfev=200, skip=SKIP, process_noise=True
        ).fit(u=us[:n], y=ys[:n], ts=1 / FS)
        wall = time.perf_counter() - t0
        test = ident.rmse(yt[SKIP:], np.asarray(m.predict(u=ut)).ravel()[SKIP:]) * 1e3
        val = m.score(u=us[n:], y=ys[n:], skip=SKIP, expected=True)["fit"][0]
        pn = m.info["process_noise"]
        shape = np.round(10 * np.log10(np.asarray(pn["noise_density"])), 1)
        print(
            f"{p}p{z}z: test {test:.2f} mV, validation {val:.2f} %, {m.info['build']}, level "
            f"{pn['sigma_per_spread']:.2f}, period power {pn['power_ratio']:.3f} +- {pn['power_ratio_error']:.3f} "
            f"({'consistent' if pn['consistent'] else 'refuted'}), noise shape dB {shape.tolist()}, {wall:.0f} s",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
