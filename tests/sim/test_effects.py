"""Named extra effects: off by default, each measurable when switched on."""

import numpy as np
import pytest

from porosense.errors import InputError
from porosense.sim import EFFECT_NAMES, make_plant, resolve_effects, run_experiment


def contractor(effects=None, experiment="step_40"):
    return run_experiment("contractor", experiment, porosity=82, seed=7, effects=effects)


@pytest.fixture(scope="module")
def clean():
    return contractor()


def window(rec, name, t0, t1):
    m = (rec.t >= t0) & (rec.t < t1)
    return np.asarray(rec[name], dtype=float)[m]


def test_names_match_the_diagnosis_causes_and_default_off():
    assert set(EFFECT_NAMES) == {
        "drift",
        "time_delay",
        "periodic_disturbance",
        "saturation",
        "load_dependence",
        "slow_relaxation",
        "cross_coupling",
        "outliers",
    }
    assert make_plant("contractor").effects == {}
    assert resolve_effects({"drift": {"rate_pct_per_min": 3}})["drift"]["rate_pct_per_min"] == 3.0
    with pytest.raises(InputError):
        resolve_effects(["humidity"])


def test_drift(clean):
    rec = contractor(["drift"])
    shift = window(rec, "dR_0", 60, 65).mean() - window(clean, "dR_0", 60, 65).mean()
    assert shift > 0.8  # 1.5 %/min over ~1 min of record


def test_time_delay(clean):
    rec = contractor({"time_delay": {"delay_s": 0.3}})

    def crossing(r):
        m = r.t > 5.0
        return r.t[m][np.argmax(r["dR_0"][m] < -20.0)]

    assert crossing(rec) - crossing(clean) == pytest.approx(0.3, abs=0.03)


def test_periodic_disturbance(clean):
    def amplitude(r):
        t, y = r.t[(r.t >= 56) & (r.t < 64)], window(r, "dR_0", 56, 64)
        w = 2 * np.pi * 7.3 * (t + 0.01)  # plant time runs one sample ahead of t
        x = t - t.mean()  # a quadratic trend absorbs the decaying overshoot
        basis = np.column_stack([np.ones_like(t), x, x**2, np.sin(w), np.cos(w)])
        coef = np.linalg.lstsq(basis, y, rcond=None)[0]
        return float(np.hypot(coef[3], coef[4]))

    assert amplitude(contractor(["periodic_disturbance"])) == pytest.approx(1.5, rel=0.15)
    assert amplitude(clean) < 0.1


def test_saturation(clean):
    # 1.8 V on the divider is dR -74 % at R0 2.2 kOhm: above the -60 kPa hold (about -83 %)
    rec = contractor({"saturation": {"low_V": 1.8}}, "step_60")
    low = window(rec, "dR_0", 12, 15).mean()
    assert low > contractor(None, "step_60")["dR_0"].min() + 5.0
    assert rec["adc_0"].min() >= int(1.8 / (4.096 / 32768)) - 1


def test_load_dependence(clean):
    rec = contractor({"load_dependence": {"delta_g": 400, "start_s": 20, "ramp_s": 5}})
    assert rec["load_g"][0] == 0.0 and rec["load_g"][-1] == pytest.approx(400.0)
    drop = window(clean, "strain_0", 53, 55).mean() - window(rec, "strain_0", 53, 55).mean()
    assert drop > 1.0  # % strain lost to the added load on the last pulse


def test_slow_relaxation(clean):
    rec = contractor(["slow_relaxation"])
    gap = window(rec, "dR_0", 62, 65).mean() - window(clean, "dR_0", 62, 65).mean()
    assert gap > 0.5  # the slow mode is still relaxing after the release


def test_cross_coupling():
    seq = dict(porosity=76, seed=3)
    on = run_experiment("3dof", "sequential_40", effects=["cross_coupling"], **seq)
    off = run_experiment("3dof", "sequential_40", **seq)
    alone0 = (on.t > 12) & (on.t < 15)
    # without the effect contractor 0 still stretches its neighbours a little through the
    # platform (the segment's axial stiffness): a few % dR of tension
    assert off["dR_1"][alone0].mean() - on["dR_1"][alone0].mean() > 2.0
    assert abs(off["dR_1"][alone0].mean()) < 4.0


def test_outliers(clean):
    rec = contractor(["outliers"])
    spikes = lambda r: int(np.sum(np.abs(np.diff(r["dR_0"])) > 10.0))
    assert rec.meta["dropped_samples"] >= 5 and len(rec) < len(clean)
    assert spikes(rec) >= 6 and spikes(clean) == 0
    assert "dropped_samples" not in clean.meta


def test_load_dependence_from_a_column_is_checked_and_runs_on_a_recording_only():
    """The measured form of load_dependence (what diagnose --save-extended writes): its column
    and unit are kept as stated, another unit or parameter is refused in one line, and a plant
    without a recording refuses it (a schedule has no load column); simulated on a record, a
    load column of zeros leaves a calibrated file's simulation (no print variation, no drift)
    unchanged (|difference| < 1e-9 %), and a record without the column is refused in one line."""
    from porosense.sim import Physics
    from porosense.sim.calibrate import ActuatorRecord, simulate_record

    spec = {"load_dependence": {"column": "load_g", "unit": "g", "factor": 0.5}}
    assert resolve_effects(spec)["load_dependence"] == {"column": "load_g", "unit": "g", "factor": 0.5}
    for bad in ({"column": "load_g", "unit": "kg"}, {"column": "load_g", "delta_g": 4.0}, {"column": ""}):
        with pytest.raises(InputError) as err:
            resolve_effects({"load_dependence": bad})
        assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="column 'load_g'"):
        make_plant("contractor", effects=spec)
    physics = Physics().without("repeat_variation", "baseline_drift")  # as a calibrated file has it
    rec = contractor(experiment="step_20")
    p = np.asarray(rec["p_cmd_0"], dtype=float)[:, None]
    ar = ActuatorRecord(p, 1.0 / rec.meta["rate_hz"], np.zeros_like(p), load_g=np.zeros(p.shape[0]))
    base = simulate_record("contractor", physics, ar)["dR_0"]
    assert np.max(np.abs(simulate_record("contractor", physics, ar, effects=spec)["dR_0"] - base)) < 1e-9
    with pytest.raises(InputError, match="no load column 'load_g'"):
        simulate_record("contractor", physics, ActuatorRecord(p, ar.ts, np.zeros_like(p)), effects=spec)
