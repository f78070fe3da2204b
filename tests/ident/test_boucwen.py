"""The Bouc-Wen hysteresis benchmark (Noel & Schoukens 2016; official simulator data, 750 Hz).

CI size: estimation on periods 1-3 of the 5-period training multisine (the first period is
simulated but not scored: it holds the transient), selection on period 5 (the record is
simulated from rest over all 5 periods and scored on the last), test on the official
multisine (one steady-state period: two are simulated, the second is scored). Grid: the four
structures at 2 poles and 1 zero (the oscillator's order).
"""

import numpy as np
import pytest

from porosense import ident
from porosense.data import read_table

PERIOD = 8192
RATIO_BOUND = 0.95  # selected / linear test RMSE; measured 0.886 (see the test's docstring)


@pytest.fixture(scope="module")
def boucwen(shared_data):
    folder = shared_data / "boucwen"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    tr = read_table(folder / "train_multisine_5periods.csv")
    te = read_table(folder / "test_multisine.csv")
    return tr.columns["u_N"], tr.columns["y_m"], te.columns["u_N"], te.columns["y_m"]


@pytest.mark.slow
def test_selected_model_validates_and_tests_at_least_as_well_as_linear(boucwen):
    """Measured: selected WH (wiener+linear build) validation fit 75.59 % against linear 72.55 %;
    test RMSE 1.477e-4 m against linear 1.667e-4 m (ratio 0.886; Hammerstein 1.711e-4, Wiener
    1.635e-4). Published: 4.52e-5 m (dynoNet), 1.87e-5 m (decoupled PNLSS)."""
    u, y, tu, ty = boucwen
    est_u, est_y = [u[: 3 * PERIOD, None]], [y[: 3 * PERIOD]]
    res = ident.search(
        u=est_u,
        y=est_y,
        ts=1 / 750,
        skip=PERIOD,
        validation=([u[:, None]], [y]),
        validation_skip=[4 * PERIOD],
        grid=[(s, 2, 1) for s in ident.KINDS],
        criterion="fit",
        max_nfev=60,
        starts=1,
        progress=False,
    )
    print(res)
    per = res.best_per_structure("fit")

    def test_rmse(model):
        return ident.rmse(ty, model.predict(u=np.vstack([tu[:, None], tu[:, None]]))[len(ty) :])

    err = {k: test_rmse(c.model) for k, c in per.items()}
    sel = test_rmse(res.best.model)
    print(
        "test RMSE (m):",
        {k: f"{v:.3e}" for k, v in err.items()},
        "selected",
        f"{sel:.3e}",
        "ratio",
        sel / err["linear"],
    )
    assert res.best.validation_fit >= per["linear"].validation_fit
    assert sel <= RATIO_BOUND * err["linear"]
