"""How far the noise-aware deconvolution of g can go on the measured WH process-noise benchmark
when the linear blocks are right.

A WH model fitted on the noise-free test multisine (WH_TestDataset) supplies H1 and H2 (test
RMSE about 0.8 mV); on 5 estimation realisations, g is re-solved for the expected output at
several noise levels (fractions of the spread of g's input) with the identification's smoothness
penalty, and the noise-free model is scored on the test multisine (mV). This is a look at the
ceiling, not a method: the blocks come from the test data.
Run: .venv/bin/python tools/explore/wh_oracle_blocks.py
"""

import sys
from dataclasses import replace

import numpy as np
from wh_benchmark import tables

from porosense import ident
from porosense.ident import process_noise, refine
from porosense.ident.chain import Chain

SKIP = 200


def main() -> int:
    est, test = tables()
    ut, yt = test.columns["u_0"][:, None], test.columns["y_0"]
    oracle = ident.WienerHammerstein(n_poles=6, n_zeros=5, n_breakpoints=10, skip=SKIP, starts=1).fit(
        u=ut, y=yt, ts=1.0 / float(est.columns["fs"][0])
    )
    print(
        f"blocks from the test multisine: {oracle.info.get('build')}, test RMSE "
        f"{ident.rmse(yt[SKIP:], oracle.predict(u=ut)[SKIP:]) * 1e3:.2f} mV"
    )
    us = [est.columns[f"u_{i}"][:, None] / oracle.u_scale for i in range(5)]
    ys = [(est.columns[f"y_{i}"] - oracle.y_mean) / oracle.y_std for i in range(5)]
    fit = refine.Fit(oracle.spec, oracle.theta, 0.0)
    spec = replace(oracle.spec, g_noise=True)
    spread = float(np.std(np.concatenate([Chain(fit.spec, fit.theta).linear_sum(u)[SKIP:] for u in us])))
    for smoothness in (1e-4, 1e-3):
        opts = refine.Options(skip=SKIP, smoothness=smoothness)
        row = []
        for frac in (0.0, 0.6, 0.8, 1.0, 1.2, 1.5):
            sigma = max(frac, 1e-6) * spread
            g = process_noise.at_noise_level(fit, spec, us, ys, sigma, opts, refine_blocks=False)
            z = Chain(spec, g.theta).simulate(ut / oracle.u_scale, expected=False) * oracle.y_std + oracle.y_mean
            row.append(f"{frac:.1f}: {ident.rmse(yt[SKIP:], z[SKIP:]) * 1e3:.1f}")
        print(f"smoothness {smoothness:g}, test RMSE (mV) per noise level / spread of g's input: " + ", ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
