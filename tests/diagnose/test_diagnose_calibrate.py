"""The ``--sim`` nominal (porosense.diagnose.calibrate): the simulator's mean recording, each record
with its own recording state fitted within the simulator's stated spread (99 % prior interval).

1. The state follows what the recordings differ by: contractor records of one print, each
   recording with its own draw of porosense.sim.variation (sensitivity, kinetics, softening, R0
   drift) and noise; the simulator calibrated on staircase + step_60 of one recording pair, the
   state fitted on a step_40 record of a third. Bound: in each of 4 trials the fitted sensitivity
   and kinetics factors are within 0.06 and 0.05 of the drawn ones (two standard deviations of the
   drawn 3 %, a third of the drawn 15 %) and the record fits >= 98 %. Measured (seeds 5000-5300):
   sensitivity within 0.048, kinetics within 0.010, fits 99.2-99.4 %. The records come from the
   simulator whose spread the state stands for (porosense.sim, not the code under test).
2. A cause beyond the prior is not swallowed: the same kind of records with an R0 drift of
   2 %/min (porosense.sim effect ``drift``, beyond the recordings' own 0.3 %/min rms) in the
   validation record, through ``porosense diagnose --sim contractor``: every record's state is
   reported by file and part; the validation record's drift sits at the prior's bound
   (2.576 x 0.3 %/min), the rest of the 2 %/min is left in the residual, and the estimation
   records' drift is inside the bound. Measured: +0.008 and +0.452 %/min on estimation, +0.773 on
   validation.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from porosense import sim
from porosense.cli import main
from porosense.diagnose.calibrate import Z_PRIOR, calibrate
from porosense.sim import Physics
from porosense.sim.variation import draw_channels

RATE_HZ = 20.0


def _record_draw(seed: int):
    """The recording's own factors (the print's draws left out): one channel."""
    v = dict.fromkeys(("contact_strain_sd", "floor_sd", "modulus_sd", "relax_gain_sd", "kinetics_sd", "r0_sd"), 0.0)
    return draw_channels(Physics().with_(variation=v), 0, seed, 1)[0]


@pytest.mark.parametrize("base", (5000, 5100, 5200, 5300))
def test_the_record_state_follows_the_recordings_draw(base):
    recs = [
        sim.run_experiment("contractor", e, porosity=80.0, rate_hz=RATE_HZ, seed=base + k)
        for k, e in enumerate(("staircase", "step_60", "step_40"))
    ]
    u = [r["p_cmd_0"][:, None] for r in recs]
    cal = calibrate("contractor", "dR_0", u[:2], [r["dR_0"] for r in recs[:2]], 1.0 / RATE_HZ)
    _, state = cal.predict_record(u[2], recs[2]["dR_0"], 1.0 / RATE_HZ)
    pz = Physics().piezo
    d = _record_draw(base + 2)
    assert abs(state.gain - d.piezo.floor_pct / pz.floor_pct) <= 0.06, (state, d)
    assert abs(state.kinetics - d.piezo.form_s / pz.form_s) <= 0.05, (state, d)
    assert state.fit >= 98.0, state


def _drift_files(folder: Path, rate_pct_per_min: float):
    files = []
    for k, name in enumerate(("staircase", "step_60", "step_40")):
        effects = {"drift": {"rate_pct_per_min": rate_pct_per_min}} if name == "step_40" else None
        rec = sim.run_experiment("contractor", name, porosity=80.0, rate_hz=RATE_HZ, seed=6000 + k, effects=effects)
        path = folder / f"{name}.csv"
        rec.to_csv(path)
        files.append(str(path))
    return files


def test_a_drift_beyond_the_prior_is_not_swallowed_and_every_state_is_reported(tmp_path, capsys):
    files = _drift_files(tmp_path, 2.0)
    argv = ["diagnose", "--sim", "contractor", "--data", *files[:2], "--validation-data", files[2]]
    assert main(argv + ["--input", "p_cmd_0", "--output", "dR_0", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    states = doc["record_states"]
    assert [(Path(s["data"]).name, s["part"]) for s in states] == [
        ("staircase.csv", "estimation"),
        ("step_60.csv", "estimation"),
        ("step_40.csv", "validation"),
    ]
    bound = Z_PRIOR * Physics().variation.drift_pct_per_min_sd
    val = states[2]
    with capsys.disabled():
        print("drift per record (%/min):", [round(s["drift"], 3) for s in states], f"bound {bound:.3f}")
    assert val["drift"] == pytest.approx(bound, rel=1e-6) and "drift" in val["at_bound"], val
    assert all(abs(s["drift"]) < bound for s in states[:2]), states


def test_an_output_without_a_recording_state_is_the_mean_recording():
    """Curvature (camera) has no piezoresistive state: every record is the calibrated mean recording
    (measured fit 95.8 % on the held-out step_40; bound 90 %)."""
    recs = [
        sim.run_experiment("bending", e, rate_hz=RATE_HZ, seed=7 + k) for k, e in enumerate(("staircase", "step_40"))
    ]
    u = [r["p_cmd_0"][:, None] for r in recs]
    cal = calibrate("bending", "curvature", u[:1], [recs[0]["curvature"]], 1.0 / RATE_HZ)
    yhat, state = cal.predict_record(u[1], recs[1]["curvature"], 1.0 / RATE_HZ)
    assert np.array_equal(yhat, cal.predict(u[1], 1.0 / RATE_HZ))
    assert state.at_bound == () and state.fit >= 90.0, state


@pytest.mark.parametrize("leak", [0.0, 0.25])
def test_a_calibration_the_print_cannot_follow_says_so(leak):
    """A 3-DoF segment whose contractor 0 reads its neighbours' strain (a leak the simulator
    lacks) pulls the porosity to its bound; a clean one stays inside (porosity drawn at 76 %)."""
    effects = {"cross_coupling": {"gain": leak}} if leak else None
    us, ys = [], []
    for k, exp in enumerate(("sequential_60", "two_level")):
        rec = sim.run_experiment("3dof", exp, porosity=76.0, rate_hz=20, seed=4100 + k, effects=effects)
        us.append(np.column_stack([rec[f"p_cmd_{c}"] for c in range(3)]))
        ys.append(rec["dR_0"])
    cal = calibrate("3dof", "dR_0", us, ys, 0.05)
    assert cal.porosity_at_bound == bool(leak), cal.porosity


def test_a_calibration_with_the_effect_the_records_hold_fits_them_better():
    """``calibrate(effects=...)`` runs the simulator with named effects (what the oracle of
    tools/sim_diagnosis_oracle.py calibrates): records with a 0.3 s dead time are fitted better
    with it than without."""
    effects = {"time_delay": {"delay_s": 0.3}}
    us, ys = [], []
    for k, exp in enumerate(("staircase", "step_60")):
        rec = sim.run_experiment("contractor", exp, porosity=80.0, rate_hz=20, seed=4300 + k, effects=effects)
        us.append(rec["p_cmd_0"][:, None])
        ys.append(rec["dR_0"])
    without = calibrate("contractor", "dR_0", us, ys, 0.05)
    with_it = calibrate("contractor", "dR_0", us, ys, 0.05, effects=effects)
    print(f"fit without the delay {without.fit_estimation:.2f} %, with it {with_it.fit_estimation:.2f} %")
    # the oracle gains 6-15 points on held-out records with 0.15-0.5 s delays
    assert with_it.fit_estimation >= without.fit_estimation + 5.0
