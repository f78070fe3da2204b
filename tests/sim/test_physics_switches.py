"""Each effect of the simulator beyond a Wiener-Hammerstein chain (porosense.sim.params.
PHYSICS_EFFECTS, issue 31 item 1) is switched off by its name, and switching it off changes
the record it acts on; switched off, the relaxation leaves no overshoot above R0 after a
release (the paper's overshoot is the relaxation's).

Records: the paper's -40 kPa steps at 25 Hz (contractor; the 3-DoF segment for its axial
stiffness), one seed, noise on except where the effect is the noise. A switch "changes the
record" when the largest difference of the column it acts on exceeds 0.01 % dR (0.05 % of the
column's span for outputs), far above the float round-off of a deterministic replay (0 here:
the same seed gives the same record).
"""

from __future__ import annotations

import numpy as np
import pytest

from porosense.sim import Physics, run_experiment
from porosense.sim.analysis import release_overshoots
from porosense.sim.params import PHYSICS_EFFECTS

#: effect -> (actuator, column it acts on)
ACTS_ON = {
    "rate_hysteresis": ("contractor", "dR_0"),
    "relaxation": ("contractor", "dR_0"),
    "log_relaxation": ("contractor", "dR_0"),
    "softening": ("contractor", "dR_0"),
    "repeat_variation": ("contractor", "dR_0"),
    "baseline_drift": ("contractor", "dR_0"),
    "sensor_noise": ("contractor", "dR_0"),
    "regulator_noise": ("contractor", "strain_0"),
    "segment_stiffness": ("3dof", "dz"),
}
SEED = 3


def _record(actuator: str, physics: Physics):
    return run_experiment(actuator, "step_40", rate_hz=25.0, seed=SEED, physics=physics)


def test_every_effect_has_a_switch_here():
    assert set(ACTS_ON) == set(PHYSICS_EFFECTS)


@pytest.mark.parametrize("effect", PHYSICS_EFFECTS)
def test_switching_an_effect_off_changes_what_it_acts_on(effect):
    actuator, col = ACTS_ON[effect]
    default = np.asarray(_record(actuator, Physics())[col])
    again = np.asarray(_record(actuator, Physics())[col])
    off = np.asarray(_record(actuator, Physics().without(effect))[col])
    change = float(np.max(np.abs(off - default)))
    bound = 0.01 if col.startswith("dR") else 0.0005 * float(np.ptp(default))
    print(f"{effect}: largest change of {col} {change:.4g} (bound {bound:.3g})")
    assert np.array_equal(default, again)
    assert change > bound, (effect, change)


def test_without_relaxation_no_overshoot_above_r0():
    """Noiseless, no drift: the default overshoots above R0 after each release (>= 2 % dR at
    -40 kPa, tests/sim/test_done_when.py); without the relaxation the peak stays below 0.1 % dR."""
    base = Physics().without("baseline_drift")
    with_relax = release_overshoots(run_experiment("contractor", "step_40", seed=SEED, noise=False, physics=base))
    without = release_overshoots(
        run_experiment("contractor", "step_40", seed=SEED, noise=False, physics=base.without("relaxation"))
    )
    print(
        "peaks with / without relaxation:",
        [round(s.peak_pct, 3) for s in with_relax],
        [round(s.peak_pct, 3) for s in without],
    )
    assert min(s.peak_pct for s in with_relax) >= 2.0
    assert max(s.peak_pct for s in without) < 0.1
