"""Every process-noise build of ``identify --process-noise`` on the measured WH benchmark, side by side.

WH 6 poles / 3 zeros (or the order given as poles,zeros), 10 breakpoints, one start, the default
200 evaluations, as ``porosense bench ident`` runs it. Each output-error build (BLA split, Wiener + linear,
linear + Hammerstein, their starts) is refined with its noise level measured from the
repeated periods; printed per build: its expected-output error relative to the lowest
(the tie rule keeps the fewest parameters within one standard error, also printed), the level
(x the spread of g's input), the noise-free multisine test RMSE (mV) and whether white noise at
g's input explains the colour of the period differences (porosense.ident.noise_colour: the
chi-square misfit over the bands and its p-value), and the RMS distance (mV) of its noise-free
output on the estimation inputs from the build the tie rule keeps. Then the output-error builds'
test RMSE, and the deconvolution check of the kept build as the estimator makes it
(process_noise.deconvolution_spread: its move from its output-error fit against the spread of the
tied builds).
``--starts K``: starts per nonlinear model (default 1; ``identify`` uses 2).
Run: .venv/bin/python tools/explore/wh_process_noise_builds.py [N | A-B realisations, default 5] [poles,zeros] [--starts K]
"""

import sys
from functools import partial

import numpy as np
from wh_benchmark import realisations, records

from porosense import ident
from porosense.ident import noise_level, output_error, process_noise, refine
from porosense.ident.chain import Chain
from porosense.ident.metrics import relative_standard_error

SKIP = 200


def main() -> int:
    argv = sys.argv[1:]
    starts = 1
    if "--starts" in argv:
        k = argv.index("--starts")
        starts = int(argv[k + 1])
        argv = argv[:k] + argv[k + 2 :]
    args = [a for a in argv if "," not in a]
    order = [tuple(map(int, a.split(","))) for a in argv if "," in a] or [(6, 3)]
    which = realisations(args[0] if args else "5")
    us, ys, ut, yt = records(which)
    scale = np.max(np.abs(np.vstack(us)), axis=0)
    all_y = np.concatenate(ys)
    mean, std = float(np.mean(all_y)), float(np.std(all_y))
    nus, nys = [u / scale for u in us], [(y - mean) / std for y in ys]
    opts = refine.Options(skip=SKIP, starts=starts, max_nfev=200)
    oe = output_error.wh_fits(nus, nys, *order[0], 10, 0, opts)
    periods = noise_level.PeriodData(nus, nys, SKIP)
    builds = process_noise.map_builds(
        partial(process_noise.noise_from_periods, us=nus, ys=nys, opts=opts, periods=periods), oe
    )
    low = min(f.sse for f in builds)
    n_res = sum(len(y) - SKIP for y in ys)
    tied = process_noise.within_noise([f for f in builds if f.notes["process_noise"]["consistent"]], n_res)
    kept = min(tied, key=lambda f: (f.spec.n_params, f.sse)) if tied else None

    def noise_free(f, u):
        return Chain(f.spec, f.theta).simulate(u / scale, expected=False) * std + mean

    def distance_mv(f) -> float:
        d = np.concatenate([(noise_free(f, u) - noise_free(kept, u))[SKIP:] for u in us])
        return float(np.sqrt(np.mean(d**2))) * 1e3

    print(
        f"realisations {which[0]}-{which[-1]}, {order[0][0]}p{order[0][1]}z; tie: within "
        f"{200 * relative_standard_error(n_res):.2f} % of the lowest error"
    )
    for f in builds:
        z = noise_free(f, ut)
        pn = f.notes["process_noise"]
        print(
            f"{'*' if f is kept else ' '} {f.build}: {f.spec.n_params} parameters, error {100 * (f.sse / low - 1):+.2f} %, "
            f"level {pn['sigma_per_spread']:.2f}{'' if pn['consistent'] else ' (period power refuted)'}, test RMSE "
            f"{ident.rmse(yt[SKIP:], z[SKIP:]) * 1e3:.2f} mV, noise-free {distance_mv(f) if kept else np.nan:.2f} mV "
            f"from the kept build, colour misfit {pn['colour']['statistic']:.1f} on {pn['colour']['dof']} dof "
            f"(p = {pn['colour']['p_value']:.2g})"
        )
    for f in oe:
        print(f"  output error {f.build}: test RMSE {ident.rmse(yt[SKIP:], noise_free(f, ut)[SKIP:]) * 1e3:.2f} mV")
    if kept is not None:
        parent = oe[next(i for i, f in enumerate(builds) if f is kept)]  # by identity: Fits hold arrays
        d = process_noise.deconvolution_spread(kept, parent, tied, nus, SKIP)
        print(
            f"deconvolution check of the kept build: moved {d['correction'] * std * 1e3:.2f} mV from its output-error "
            f"fit, spread {d['spread'] * std * 1e3:.2f} mV over {d['tied_builds']} tied builds: "
            f"{'determined, kept' if d['determined'] else 'undetermined, the output-error fit stays'}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
