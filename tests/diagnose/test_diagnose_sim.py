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
validation gain; on clean data top is none in >= 95 %. Checked at one size everywhere (CI or
not): 12 trials per cause and clean, seeds 1000-1011 (the clean 3-DoF segment: 3000-3011) (4 trials were run before; they were measured
unrepresentative of the next eight: cross_coupling 4/4 at 1000-1003, 1/8 at 1004-1011).

Measured on the simulator of issue 31 (physics beyond WH; every recording draws its own sensor
sensitivity, contact-law scale, kinetics, softening state and R0 drift, as real repeats differ),
against the --sim nominal of porosense.diagnose.calibrate: the simulator's mean recording, each
record with its own recording state fitted within the 99 % interval of the simulator's stated
spread (porosense.sim.params.Variation) and refitted beside every correction and extension with
its Gaussian prior (so a cause the state partly mimics keeps its gain). Top-1 at seeds
1000-1011 (``python tools/sim_diagnosis_variation.py as_it_is``): saturation,
periodic_disturbance, outliers 12/12; time_delay 10/12; load_dependence, static_nonlinearity
9/12; hysteresis 8/12; cross_coupling, drift 7/12; slow_relaxation 1/12 (87 of 120); clean
contractor records named none 12/12, the clean 3-DoF segment 12/12. Every cause below its bound
is a strict xfail naming what is named instead.

Where the misses come from: causes a recording's own state within its prior partly explains (a
rate-independent memory or a slow relaxation looks like slower contact kinetics or a softening
state; a drift's held-out gain cannot be confirmed on a validation record whose own drift state
is at its bound), and the engine's own misses
without any recording variation (``python tools/sim_diagnosis_variation.py off_in_both``). The
simulator given the true effect, calibrated as the nominal is, gains on the held-out record in
12/12 time_delay, load_dependence and slow_relaxation trials and 10/12 drift trials (``python
tools/sim_diagnosis_oracle.py``): slow_relaxation's 1/12 is the extension's limit, not the data's.
"""

from __future__ import annotations

import pytest

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE

TRIALS = 12
SEED = 1000
#: issue 31 item 6: a hidden cause top-1 in >= 90 % of trials, clean records named none in >= 95 %
CAUSE_BOUND, CLEAN_BOUND = 0.90, 0.95
#: measured top-1 of the causes below the bound at seeds 1000-1011 (see the module docstring)
BELOW_BOUND = {
    "drift": "7/12: named none x4, slow_relaxation",
    "time_delay": "10/12: named unmodelled_dynamics x2",
    "load_dependence": "9/12: named none, outliers, static_nonlinearity",
    "static_nonlinearity": "9/12: named none x2, hysteresis",
    "hysteresis": "8/12: named none x2, unmodelled_dynamics, slow_relaxation",
    "cross_coupling": "7/12: named none x3, unmodelled_dynamics x2",
    "slow_relaxation": "1/12: named none x4, drift x3, static_nonlinearity, periodic_disturbance, unmodelled_dynamics, time_delay",
}


def _check(cause, n, seed, run=trials.run_sim_trial):
    results = [run(cause, seed + k) for k in range(n)]
    tops = [r.top for r in results]
    rate = sum(t == cause for t in tops) / n
    bound = CLEAN_BOUND if cause == NONE else CAUSE_BOUND
    assert rate >= bound, f"{cause}: top-1 in {rate:.0%} of {n} simulator trials ({tops}), bound {bound:.0%}"
    if cause != NONE:
        gains = [r.gain for r in results if r.top == cause]
        assert all(g > 0 for g in gains), f"{cause}: validation gains {gains}"


@pytest.mark.slow
def test_sim_3dof_clean_is_none():
    _check(NONE, TRIALS, 3000, trials.run_sim_3dof_trial)


@pytest.mark.slow
@pytest.mark.parametrize(
    "cause",
    [
        pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=BELOW_BOUND[c])) if c in BELOW_BOUND else c
        for c in list(trials.SIM_CAUSES) + [NONE]
    ],
)
def test_sim_hidden_cause_found_many_trials(cause):
    _check(cause, TRIALS, SEED)
