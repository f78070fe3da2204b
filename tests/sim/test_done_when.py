"""The paper's behaviour the simulator must reproduce (issue 3, 'Done when'), each with its bound."""

import numpy as np
import pytest

from porosense.sim import Physics, run_experiment
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
    """The paper: dR beyond -80 % with strains of 20-30 %; here the most porous print passes
    -80 %, the others go past -55 % (the paper's lower porosities change less)."""
    strain, dr = at_60[phi, 0.0]
    assert -95.0 <= dr <= (-80.0 if phi == 86 else -55.0)
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


def test_load_reduces_strain_more_for_high_porosity():
    """Noiseless prints (the difference between the two drops is a few tenths of a percent)."""

    def settled(phi, load):
        return hold_mean(
            run_experiment("contractor", "step_60", porosity=phi, load_g=load, noise=False), "strain_0", -60
        )

    drop = {phi: settled(phi, 0.0) - settled(phi, 500.0) for phi in (68, 86)}
    assert drop[68] > 0.5 and drop[86] > 0.5
    assert drop[86] > drop[68] + 0.1


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
    """R overshoots R0 after every release and relaxes before the next pulse (noiseless, no
    drift: at -10 kPa the overshoot, 0.14 % dR, is below the contact noise): at least half of it
    is gone over the last 0.5 s before the next pulse, and at -40 and -60 kPa (3 and 6 % dR)
    at least 63 % (one time constant)."""
    physics = Physics().without("baseline_drift")
    rec = run_experiment("contractor", f"step_{level}", porosity=82, seed=level, noise=False, physics=physics)
    shots = release_overshoots(rec)
    assert len(shots) == 3
    for shot in shots:
        assert shot.peak_pct >= (0.1 if level < 40 else 2.0)
        assert shot.decayed >= (0.5 if level < 40 else 0.63)
