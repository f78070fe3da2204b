"""The simulator's own effects as diagnosis computes them from a calibrated simulation
(porosense.diagnose.calibrate.Simulation, what ``diagnose --sim`` tests and extends
slow_relaxation and load_dependence with) are the effects porosense.sim.plant adds.

The truth is the simulator run with the named effect less the same run without it (noise-free
contractor, staircase at 20 Hz, the mean recording of a simulator without recording variation,
so that the record's fitted state is the simulation's own). Bound: the computed effect matches
the simulator's to 1e-6 of the effect's range (a formula that started its slow lag elsewhere or
ran the load through another path would miss by percents). Measured: slow_relaxation (gain 0.15,
tau 25 s: range 8.8 % dR; gain 0.1, tau 8 s: 3.4 %) largest error 7e-15 % dR; load_dependence
(400 g ramped in from 20 s over 10 s: range 24.6 % dR) 0.
"""

from __future__ import annotations

import numpy as np
import pytest

from porosense import sim
from porosense.diagnose.calibrate import as_calibrated, mean_recording
from porosense.sim import Physics

RATE_HZ = 20.0
TS = 1.0 / RATE_HZ


def _physics():
    return mean_recording(Physics().without("repeat_variation", "baseline_drift"))


def _run(physics, p_cmd, effects=None):
    plant = sim.make_plant("contractor", noise=False, physics=physics, effects=effects)
    sp = np.zeros((len(p_cmd), 3))
    sp[:, 0] = p_cmd
    on = sp < 0.0
    return plant.run(TS, sp, on, on.copy())


@pytest.fixture(scope="module")
def record():
    p_cmd = sim.run_experiment("contractor", "staircase", rate_hz=RATE_HZ, seed=7, noise=False)["p_cmd_0"]
    ph = _physics()
    clean = _run(ph, p_cmd)
    _, state = as_calibrated("contractor", "dR_0", ph).predict_record(p_cmd[:, None], clean["dR_0"], TS)
    return ph, p_cmd, clean, state.simulation


@pytest.mark.parametrize("gain,tau_s", ((0.15, 25.0), (0.1, 8.0)))
def test_slow_relaxation_is_the_simulators(record, gain, tau_s):
    ph, p_cmd, clean, simulation = record
    truth = _run(ph, p_cmd, {"slow_relaxation": {"gain": gain, "tau_s": tau_s}})["dR_0"] - clean["dR_0"]
    computed = gain * simulation.slow_relaxation(tau_s)
    err = float(np.max(np.abs(computed - truth)))
    print(f"slow_relaxation gain {gain} tau {tau_s} s: range {np.ptp(truth):.3f} % dR, largest error {err:.2e}")
    assert err <= 1e-6 * np.ptp(truth)


def test_load_dependence_is_the_simulators(record):
    ph, p_cmd, clean, simulation = record
    ramp = {"delta_g": 400.0, "start_s": 20.0, "ramp_s": 10.0}
    loaded = _run(ph, p_cmd, {"load_dependence": ramp})
    truth = loaded["dR_0"] - clean["dR_0"]
    computed = simulation.load_dependence(loaded["load_g"])
    err = float(np.max(np.abs(computed - truth)))
    print(f"load_dependence: range {np.ptp(truth):.3f} % dR, largest error {err:.2e}")
    assert err <= 1e-6 * np.ptp(truth)
