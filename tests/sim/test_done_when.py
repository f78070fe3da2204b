"""The paper's behaviour the simulator must reproduce (issue 3, 'Done when'), each with its bound."""

import numpy as np
import pytest

from porosense.sim import run_experiment
from porosense.sim.analysis import fit_power_law, hold_mean, normalised_loop_area, release_overshoots

POROSITIES = (68, 76, 82, 86)


@pytest.fixture(scope="module")
def at_60():
    """Settled strain and dR (%) at -60 kPa per porosity, without and with 500 g."""
    out = {}
    for load in (0.0, 500.0):
        for phi in POROSITIES:
            rec = run_experiment("contractor", "step_60", porosity=phi, load_g=load, seed=phi)
            out[phi, load] = (hold_mean(rec, "strain_0", -60), hold_mean(rec, "dR_0", -60))
    return out


@pytest.mark.parametrize("phi", (76, 82, 86))
def test_contractor_ranges_at_minus_60(at_60, phi):
    strain, dr = at_60[phi, 0.0]
    assert -95.0 <= dr <= -75.0
    assert 15.0 <= strain <= 35.0


def test_lower_porosity_gives_less_strain_and_dr(at_60):
    strains = [at_60[phi, 0.0][0] for phi in POROSITIES]
    drs = [at_60[phi, 0.0][1] for phi in POROSITIES]
    assert np.all(np.diff(strains) > 0.5)  # % strain
    assert np.all(np.diff(drs) < -1.0)  # % dR (more negative)


def test_porosity_power_law(at_60):
    strain = fit_power_law(POROSITIES, [at_60[phi, 0.0][0] for phi in POROSITIES])
    dr = fit_power_law(POROSITIES, [at_60[phi, 0.0][1] for phi in POROSITIES])
    assert strain.r2 >= 0.8 and dr.r2 >= 0.8
    assert strain.n < 0 and dr.n < 0  # both grow with porosity


def test_load_reduces_strain_more_for_high_porosity(at_60):
    drop = {phi: at_60[phi, 0.0][0] - at_60[phi, 500.0][0] for phi in (68, 86)}
    assert drop[68] > 0.5 and drop[86] > 0.5
    assert drop[86] > drop[68] + 0.5


def test_rate_dependent_hysteresis_and_history_free_steady_state():
    step = run_experiment("contractor", "step_20", porosity=82, seed=1)
    stairs = run_experiment("contractor", "staircase", porosity=82, seed=2)
    cycle = (step.t >= 5.0) & (step.t < 25.0)
    step_area = normalised_loop_area(step["strain_0"][cycle], step["dR_0"][cycle])
    stair_area = normalised_loop_area(stairs["strain_0"], stairs["dR_0"])
    assert step_area > 2.0 * stair_area
    step60 = run_experiment("contractor", "step_60", porosity=82, seed=3)
    for name in ("strain_0", "dR_0"):
        full_scale = np.max(np.abs(stairs[name]))
        gap = abs(hold_mean(step60, name, -60) - hold_mean(stairs, name, -60))
        assert gap <= 0.02 * full_scale, name


@pytest.mark.parametrize("level", (10, 20, 40, 60))
def test_release_overshoot_decays_before_next_pulse(level):
    rec = run_experiment("contractor", f"step_{level}", porosity=82, seed=level)
    shots = release_overshoots(rec)
    assert len(shots) == 3
    for shot in shots:
        assert shot.peak_pct >= 1.0
        assert shot.decayed >= 0.63
