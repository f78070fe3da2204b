"""Hidden effects in the actuator simulator: porosense.sim effects, diagnosed against the
simulator calibrated on the estimation experiments (the ``--sim`` path).

Trial (porosense.diagnose.trials.run_sim_trial): contractor, porosity drawn in 72-86 %, 20 Hz;
estimation = staircase + step_60, validation = step_40 (cross_coupling: 3-DoF segment, porosity
70-82 %, estimation = sequential_60 + two_level, validation = sequential_40, diagnosis of
contractor 0 with the other two commands as unused columns). The simulator is calibrated
(porosity, scale, offset, each record's recording state) without any effect; diagnosis is not
told the cause. The load column is stated a condition and the other contractors' commands inputs
(porosense.diagnose.Record.column_kinds), as ``porosense diagnose`` reads them from their units.
Strength ranges, drawn uniformly (porosense.diagnose.trials.SIM_STRENGTHS):

- drift: rate_pct_per_min 1-3 % of R0 per minute
- time_delay: delay_s 0.15-0.5 s
- periodic_disturbance: amplitude_pct 1-3 % dR at freq_hz 1-9 Hz
- saturation: low_V at the divider voltage the clean step_40 record stays above for 80-95 % of
  its samples
- load_dependence: delta_g 200-500 g ramped in from 10-30 s over 5-15 s (in every record)
- slow_relaxation: gain 0.1-0.2 of the change in dR, tau_s 15-40 s
- outliers: glitch_pct 10-30 % dR with probability 0.3-1 % per sample
- static_nonlinearity: bend s in [0.4, 0.9] on the normalised measured dR
- hysteresis: rate-independent lag of the measured dR, memory 5-15 %, weight 0.3-0.6
- cross_coupling: gain 0.1-0.3 of the neighbours' strain into contractor 0's contact strain

Bound (issues 8 and 31): the hidden cause is top-1 in >= 90 % of trials with a positive
validation gain; on clean data top is none in >= 90 %. Checked at one size everywhere (CI or
not): 4 trials per cause, seeds 1000-1003.

Measured on the simulator of issue 31 (physics beyond WH; every recording draws its own sensor
sensitivity, contact-law scale, kinetics, softening state and R0 drift, as real repeats differ),
against the --sim nominal of porosense.diagnose.calibrate: the simulator's mean recording, each
record with its own recording state fitted within the 99 % interval of the simulator's stated
spread (porosense.sim.params.Variation). Top-1 at seeds 1000-1003
(``python tools/sim_diagnosis_variation.py as_it_is``): saturation, periodic_disturbance and
outliers 4/4; drift, time_delay, static_nonlinearity, load_dependence 3/4; hysteresis 1/4;
slow_relaxation 0/4; cross_coupling 4/4 at these seeds but 1/8 at 1004-1011, so it is run on 12
trials (29 of 40 at seeds 1000-1003; 10 before the recording states); clean
contractor records named none 4/4 (1/4 before), the clean 3-DoF segment 2/2 (0/2 before). Every
cause below the bound is a strict xfail naming what is named instead.

Where the misses come from (the same trials with the recordings' variation and R0 drift,
``repeat_variation`` and ``baseline_drift`` of porosense.sim.params.PHYSICS_EFFECTS, switched off
in the records and in the nominal: ``python tools/sim_diagnosis_variation.py off_in_both``): 32 of
40, clean 4/4 (drift, time_delay, periodic_disturbance, outliers, hysteresis 4/4; saturation,
static_nonlinearity 3/4; load_dependence, slow_relaxation, cross_coupling 2/4). The trials
between the two are causes a recording's own state within its prior partly explains: a
rate-independent memory or a slow relaxation looks like slower contact kinetics (the kinetics state
of the hysteresis trials sits at its bound, x1.47) or a softening state, a drift of 1.76 %/min
(seed 1002) loses 0.77 %/min to the drift state; what is left gains less than the test can confirm.
"""

from __future__ import annotations

import pytest

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE

TRIALS = 4
SEED = 1000
#: causes whose first four trials were measured unrepresentative of the next eight: run on twelve
TRIALS_OF = {"cross_coupling": 12}
#: measured top-1 of the causes below the bound at seeds 1000-1003 (see the module docstring)
BELOW_BOUND = {
    "drift": "3/4: seed 1002 (1.76 %/min) named none",
    "time_delay": "3/4: seed 1000 named unmodelled_dynamics",
    "static_nonlinearity": "3/4: seed 1002 named none",
    "load_dependence": "3/4: seed 1001 named none",
    "hysteresis": "1/4: named drift twice, none",
    "cross_coupling": "5/12: 4/4 at seeds 1000-1003, 1/8 at 1004-1011 (gains 0.10-0.13 are absorbed by the calibration)",
    "slow_relaxation": "0/4: named unmodelled_dynamics, drift, none twice",
}


def _check(cause, n, seed, run=trials.run_sim_trial):
    results = [run(cause, seed + k) for k in range(n)]
    tops = [r.top for r in results]
    rate = sum(t == cause for t in tops) / n
    assert rate >= 0.9, f"{cause}: top-1 in {rate:.0%} of {n} simulator trials ({tops})"
    if cause != NONE:
        gains = [r.gain for r in results if r.top == cause]
        assert all(g > 0 for g in gains), f"{cause}: validation gains {gains}"


def test_sim_3dof_clean_is_none():
    _check(NONE, 2, 3000, trials.run_sim_3dof_trial)


@pytest.mark.slow
@pytest.mark.parametrize(
    "cause",
    [
        pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=BELOW_BOUND[c])) if c in BELOW_BOUND else c
        for c in list(trials.SIM_CAUSES) + [NONE]
    ],
)
def test_sim_hidden_cause_found_many_trials(cause):
    _check(cause, TRIALS_OF.get(cause, TRIALS), SEED)
