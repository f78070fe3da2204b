"""Hidden effects in the actuator simulator: porosense.sim effects, diagnosed against the
simulator calibrated on the estimation experiments (the ``--sim`` path).

Trial (porosense.diagnose.trials.run_sim_trial): contractor, porosity drawn in 72-86 %, 20 Hz;
estimation = staircase + step_60, validation = step_40 (cross_coupling: 3-DoF segment, porosity
70-82 %, estimation = sequential_60 + two_level, validation = sequential_40, diagnosis of
contractor 0 with the other two commands as unused columns). The simulator is calibrated
(porosity, scale, offset) on the estimation part without any effect; diagnosis is not told the
cause. Strength ranges, drawn uniformly (porosense.diagnose.trials.SIM_STRENGTHS):

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
sensitivity, contact-law scale, softening state and R0 drift, as real repeats differ), with the
held-out ranking of issue 35: saturation 4/4 (held-out gains +5.6 to +31.0 points; 2/4, named
static_nonlinearity twice, before a pile-up where the input is further from its rest level than
elsewhere counted as clipping); every other cause is below the bound, each a strict xfail naming
what is named instead: outliers 0/4, cross_coupling 2/4,
time_delay 2/4 (1/4 before the delay's extension held the nominal's own prediction delayed),
periodic_disturbance 1/4, load_dependence 1/4, drift 0/4, slow_relaxation 0/4,
static_nonlinearity 0/4, hysteresis 0/4 (10 of 40 with saturation; 8 before); clean contractor records named none 1/4, the
clean 3-DoF segment 0/2 (outliers twice).

Where the misses come from (``python tools/sim_diagnosis_variation.py``, about 30 s CPU per
variant: the same trials with the recordings' variation and R0 drift, ``repeat_variation`` and
``baseline_drift`` of porosense.sim.params.PHYSICS_EFFECTS, switched off):

- off in the records and in the calibrated simulator: clean records named none 4/4, the causes
  14/40 (time_delay 4/4, saturation 3/4, periodic_disturbance 3/4, cross_coupling 2/4; drift
  named outliers 4/4, outliers none 3/4, static_nonlinearity none or outliers, hysteresis,
  slow_relaxation and load_dependence mostly unmodelled_dynamics): what clean records are named for is the recordings'
  own variation (an R0 drift of 0.3 %/min rms is a drift the calibrated simulation lacks), and
  the causes miss for reasons of their own as well;
- off in the records only (the calibrated simulator keeps recording seed 0's realisation, which
  ``porosense.diagnose.calibrate`` simulates: its drift rate, softening state and sensitivity):
  causes 10/40, clean 0/4;
- off in the calibrated simulator only (the mean recording as the nominal): causes 5/40, clean
  1/4; the mean recording is no better a nominal.

The calibration of the ``--sim`` path (porosity, scale, offset) cannot follow a
recording-to-recording sensor change; a calibration of the simulator's own physics
(porosense.sim.calibrate) in the ``--sim`` path, and a null that holds the recordings'
variation, are what these trials need next.
"""

from __future__ import annotations

import pytest

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE

TRIALS = 4
SEED = 1000
#: measured top-1 of the causes below the bound at seeds 1000-1003 (see the module docstring)
BELOW_BOUND = {
    "drift": "0/4: named static_nonlinearity twice, slow_relaxation, unmodelled_dynamics",
    "time_delay": "2/4: named unmodelled_dynamics, slow_relaxation",
    "periodic_disturbance": "1/4: named unmodelled_dynamics twice, hysteresis",
    "load_dependence": "1/4: named cross_coupling twice, slow_relaxation",
    "slow_relaxation": "0/4: named drift twice, unmodelled_dynamics, none",
    "outliers": "0/4: named unmodelled_dynamics twice, drift, none",
    "static_nonlinearity": "0/4: named drift, unmodelled_dynamics, slow_relaxation, none",
    "hysteresis": "0/4: named drift, unmodelled_dynamics twice, slow_relaxation",
    "cross_coupling": "2/4: named none, load_dependence",
    NONE: "1/4: clean records named drift, unmodelled_dynamics twice",
}


def _check(cause, n, seed, run=trials.run_sim_trial):
    results = [run(cause, seed + k) for k in range(n)]
    tops = [r.top for r in results]
    rate = sum(t == cause for t in tops) / n
    assert rate >= 0.9, f"{cause}: top-1 in {rate:.0%} of {n} simulator trials ({tops})"
    if cause != NONE:
        gains = [r.gain for r in results if r.top == cause]
        assert all(g > 0 for g in gains), f"{cause}: validation gains {gains}"


@pytest.mark.xfail(strict=True, reason="0/2: clean 3-DoF records named outliers twice (simulator of issue 31)")
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
    _check(cause, TRIALS, SEED)
