"""Does the expected-output cost tell the WH blocks apart on the measured process-noise benchmark?

Every split of the best linear approximation's poles and zeros (6 poles / 3 zeros) between H1
and H2 gets g re-solved for the expected output with a process noise of 0.9 x the spread of g's
input (the level the builds measure: 0.86-1.03); the split that fits best is refined with its
level measured from the repeated periods, like every other process-noise build. Printed: its
error against the build ``identify --process-noise`` selects (lower is better), its level
and its noise-free multisine test RMSE (mV).
Run: .venv/bin/python tools/explore/wh_noise_ranked_split.py [realisations, default 5]
"""

import sys
import time
from dataclasses import replace

import numpy as np
from wh_benchmark import TS, records

from porosense import ident
from porosense.ident import bla_split, noise_level, output_error, process_noise, refine
from porosense.ident.chain import Chain

SKIP = 200
LEVEL = 0.9


def main() -> int:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    us, ys, ut, yt = records(n)
    t0 = time.perf_counter()
    wh = ident.WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=10, skip=SKIP, starts=1, process_noise=True).fit(
        u=us, y=ys, ts=TS
    )
    selected = wh.info["sse"] / wh.y_std**2
    print(
        f"identify --process-noise ({time.perf_counter() - t0:.0f} s): {wh.info['build']}, test RMSE "
        f"{ident.rmse(yt[SKIP:], wh.predict(u=ut)[SKIP:]) * 1e3:.2f} mV"
    )
    nus = [u / wh.u_scale for u in us]
    nys = [(y - wh.y_mean) / wh.y_std for y in ys]
    opts = refine.Options(skip=SKIP)
    lin = output_error.fit_linear(nus, nys, 6, 3, 0, output_error.bla_options(opts))
    best = None
    for sse_oe, spec, theta, _, split in bla_split.ranked_split_starts(
        lin.spec, lin.theta, nus, nys, 10, SKIP, keep=10_000
    ):
        fit = refine.Fit(spec, theta, sse_oe)
        spread = float(np.std(np.concatenate([Chain(spec, theta).linear_sum(u)[SKIP:] for u in nus])))
        g = process_noise.at_noise_level(
            fit,
            replace(spec, g_noise=True),
            nus,
            nys,
            LEVEL * spread,
            replace(opts, smoothness=process_noise.NOISE_MIN_SMOOTHNESS),
            refine_blocks=False,
        )
        if best is None or g.sse < best[0]:
            best = (g.sse, fit, split)
    out = process_noise.noise_from_periods(best[1], nus, nys, opts, noise_level.PeriodData(nus, nys, SKIP))
    z = Chain(out.spec, out.theta).simulate(ut / wh.u_scale, expected=False) * wh.y_std + wh.y_mean
    print(
        f"split ranked by its noise-aware error ({best[2].describe()}): error / the selected build's "
        f"{out.sse / selected:.5f}, level {out.notes['process_noise']['sigma_per_spread']:.2f} x the spread, "
        f"test RMSE {ident.rmse(yt[SKIP:], z[SKIP:]) * 1e3:.2f} mV"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
