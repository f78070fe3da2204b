"""The paper's ranking on simulated paper experiments (porosense.sim).

Estimation: staircase, -10 and -60 kPa steps; validation: -20 and -40 kPa steps (DESIGN.md);
input dR_0 / 100, output strain_0 (contractor) or curvature (bending). To stay quick the
recordings are simulated at 10 Hz and the grid is poles 1..4 with at most 2 zeros
(WH with 4 poles and 2 zeros contains every Wiener model of that grid up to 2 poles).
"""

import pytest

from porosense import ident

sim = pytest.importorskip("porosense.sim")

RATE_HZ = 10.0
ESTIMATION = ("staircase", "step_10", "step_60")
VALIDATION = ("step_20", "step_40")
OUTPUT = {"contractor": "strain_0", "bending": "curvature"}


@pytest.mark.slow
@pytest.mark.parametrize("actuator", ["bending", "contractor"])
def test_wh_and_hammerstein_rank_as_in_the_paper(actuator):
    recs = {e: sim.run_experiment(actuator, e, rate_hz=RATE_HZ, seed=k)
            for k, e in enumerate(ESTIMATION + VALIDATION)}
    out = OUTPUT[actuator]

    def data(names):
        return [(recs[e]["dR_0"] / 100.0)[:, None] for e in names], [recs[e][out] for e in names]

    result = ident.search(u=data(ESTIMATION)[0], y=data(ESTIMATION)[1], ts=1 / RATE_HZ,
                          validation=data(VALIDATION), poles=range(1, 5), zeros=(0, 1, 2), progress=False)
    best = {k: v.mean_fit for k, v in result.best_per_structure().items()}
    print(actuator, {k: round(v, 2) for k, v in best.items()})
    assert best["wh"] >= best["wiener"]
    assert best["hammerstein"] >= best["linear"]
