"""Hidden effects in the actuator simulator: porosense.sim effects, diagnosed against the
simulator calibrated on the estimation experiments (the ``--sim`` path).

Trial (porosense.diagnose.trials.run_sim_trial): contractor, porosity drawn in 72-86 %, 20 Hz;
the paper's design, estimation = staircase + step_10 + step_60, validation = step_20 + step_40
(trials.SIM_EXPERIMENTS; cross_coupling: 3-DoF segment, porosity
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
  its samples (the staircase, step_40 and step_60 reach it)
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
its Gaussian prior (so a cause the state partly mimics keeps its gain; the simulator's
slow_relaxation and its rival refit each validation record's state by the nominal's own rule,
bounded to the 99 % interval, so that its gain is not the refit's). The causes the simulator
carries as named effects (slow_relaxation, time_delay, load_dependence) are tested and extended
as that effect computed from each record's calibrated simulation (calibrate.Simulation); the
hysteresis extension's memory form is chosen by leave-one-record-out prediction error. Top-1 at
seeds 1000-1011 (``python tools/sim_diagnosis_variation.py as_it_is``): time_delay,
periodic_disturbance, saturation, load_dependence, outliers, static_nonlinearity, hysteresis
12/12; drift, slow_relaxation, cross_coupling 11/12 (117 of 120); clean contractor records named
none 12/12, the clean 3-DoF segment 12/12. At seeds the test does not run, 1012-1023 (``python
tools/sim_diagnosis_variation.py as_it_is --seeds 1012-1023``): 116 of 120 (static_nonlinearity and
hysteresis 10/12, the rest 12/12), clean 12/12 and 12/12; over the 24 seeds every cause is top-1
in at least 22 of 24 trials (92 %).

The misses (each trial's finding: ``python tools/sim_diagnosis_findings.py CAUSE``; what the true
effect gains: ``python tools/sim_diagnosis_oracle.py CAUSE``): drift 1005 is the trial where the
simulator given the true drift, calibrated as the nominal is, does not gain on the held-out
records either (oracle confirmed 11/12, t 0.64 at 1005); slow_relaxation 1005 (test F 10.55 not
significant, gain +0.13 points, t 1.17) is where the oracle is only just confirmed (+0.21, t 1.79):
both are the data's limit at these strength ranges. cross_coupling 1009 is named none: its gain,
+2.26 points, is not confirmed (t 1.54).
"""

from __future__ import annotations

import pytest

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE

TRIALS = 12
SEED = 1000
#: issue 31 item 6: a hidden cause top-1 in >= 90 % of trials, clean records named none in >= 95 %
CAUSE_BOUND, CLEAN_BOUND = 0.90, 0.95


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
@pytest.mark.parametrize("cause", list(trials.SIM_CAUSES) + [NONE])
def test_sim_hidden_cause_found_many_trials(cause):
    _check(cause, TRIALS, SEED)
