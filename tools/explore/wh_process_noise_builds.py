"""Every process-noise build of ``identify --process-noise`` on the measured WH benchmark, side by side.

WH 6 poles / 3 zeros (or the order given as poles,zeros), 10 breakpoints, one start, the default
200 evaluations, as ``porosense bench ident`` runs it. Each output-error build (BLA split, Wiener + linear,
linear + Hammerstein, their starts) is refined with its noise level measured from the
repeated periods; printed per build: its expected-output error relative to the lowest
(the tie rule keeps the fewest parameters within one standard error, also printed), the level
(x the spread of g's input), the noise-free multisine test RMSE (mV) and whether white noise at
g's input explains the colour of the period differences (porosense.ident.noise_colour: the
chi-square misfit over the bands and its p-value).
Run: .venv/bin/python tools/explore/wh_process_noise_builds.py [realisations, default 5] [poles,zeros]
"""

import sys
from functools import partial

import numpy as np

from porosense import ident
from porosense.ident import estimate, noise_level
from porosense.ident.chain import Chain
from porosense.ident.metrics import relative_standard_error
from wh_benchmark import records

SKIP = 200


def main() -> int:
    args = [a for a in sys.argv[1:] if "," not in a]
    order = [tuple(map(int, a.split(","))) for a in sys.argv[1:] if "," in a] or [(6, 3)]
    n = int(args[0]) if args else 5
    us, ys, ut, yt = records(n)
    scale = np.max(np.abs(np.vstack(us)), axis=0)
    all_y = np.concatenate(ys)
    mean, std = float(np.mean(all_y)), float(np.std(all_y))
    nus, nys = [u / scale for u in us], [(y - mean) / std for y in ys]
    opts = estimate.Options(skip=SKIP, starts=1)
    oe = estimate.wh_fits(nus, nys, *order[0], 10, 0, opts)
    periods = noise_level.PeriodData(nus, nys, SKIP)
    builds = estimate._map_builds(partial(estimate._noise_from_periods, us=nus, ys=nys, opts=opts, periods=periods), oe)
    low = min(f.sse for f in builds)
    n_res = sum(len(y) - SKIP for y in ys)
    print(f"{n} realisations, {order[0][0]}p{order[0][1]}z; tie: within {200 * relative_standard_error(n_res):.2f} % of the lowest error")
    for f in builds:
        z = Chain(f.spec, f.theta).simulate(ut / scale, expected=False) * std + mean
        pn = f.notes["process_noise"]
        print(f"{f.build}: {f.spec.n_params} parameters, error {100 * (f.sse / low - 1):+.2f} %, level "
              f"{pn['sigma_per_spread']:.2f}, test RMSE {ident.rmse(yt[SKIP:], z[SKIP:]) * 1e3:.2f} mV, colour misfit "
              f"{pn['colour']['statistic']:.1f} on {pn['colour']['dof']} dof (p = {pn['colour']['p_value']:.2g})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
