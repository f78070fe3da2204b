"""SysIdentPy's polynomial NARX, run in its own environment (tools/peers/requirements.txt).

SysIdentPy pins an older numpy than porosense, so it lives in .venv-peers (made by
tools/bootstrap.sh) and porosense's benchmark calls this script there:

    .venv-peers/bin/python tools/peers/narx_peer.py IN.npz OUT.npz

IN.npz holds u_est, y_est, u_test, y_test (1-D), lags and degree; OUT.npz gets yhat (the free-run
simulation on the test record, its first ``lags`` outputs as initial state), wall_s, cpu_s and
terms. Only numpy and SysIdentPy are imported here.
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np


def main(src: str, dst: str) -> None:
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    d = np.load(src)
    lags, degree = int(d["lags"]), int(d["degree"])
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = FROLS(
            order_selection=True,
            n_info_values=15,
            ylag=lags,
            xlag=lags,
            info_criteria="aic",
            estimator=LeastSquares(),
            basis_function=Polynomial(degree=degree),
        )
        model.fit(X=d["u_est"][:, None], y=d["y_est"][:, None])
        yhat = model.predict(X=d["u_test"][:, None], y=d["y_test"][:lags, None]).ravel()
    np.savez(
        dst,
        yhat=yhat,
        wall_s=time.perf_counter() - t0,
        cpu_s=time.process_time() - c0,
        terms=len(model.final_model),
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
