"""Plant API: stepping and vectorised runs agree, readings, validation, steady state."""

import numpy as np
import pytest

from porosense.errors import InputError
from porosense.sim import Physics, make_plant, run_experiment, steady_state
from porosense.sim.analysis import hold_mean
from porosense.sim.electronics import divider_voltage, resistance_from_voltage

DETERMINISTIC_EFFECTS = [
    "drift",
    "time_delay",
    "periodic_disturbance",
    "saturation",
    "load_dependence",
    "slow_relaxation",
    "cross_coupling",
]


def actuation(n=1500, seed=0):
    rng = np.random.default_rng(seed)
    levels = rng.choice([0.0, -10.0, -25.0, -40.0, -60.0], size=(n // 100 + 1, 3))
    sp = np.repeat(levels, 100, axis=0)[:n]
    on = sp < 0
    return sp, on, on.copy()


@pytest.mark.parametrize("actuator", ["contractor", "bending", "3dof"])
def test_step_matches_vectorised_run(actuator):
    plant = make_plant(actuator, load_g=100.0, noise=False, effects=DETERMINISTIC_EFFECTS)
    sp, pump, valve = actuation()
    batch = plant.run(0.01, sp, pump, valve)
    volts = np.array([plant.step(0.01, sp[k], pump[k], valve[k]).voltage_V for k in range(len(sp))])
    assert np.max(np.abs(volts - batch["voltage_V"])) < 1e-9


def test_reading_shapes_and_truth():
    plant = make_plant("3dof", seed=4)
    for _ in range(300):
        r = plant.step(0.01, [-60.0, 0.0, 0.0], [1, 0, 0], [1, 0, 0])
    assert r.voltage_V.shape == (3,) and r.euler_deg.shape == (3,)
    assert np.allclose(r.euler_deg * 16, np.round(r.euler_deg * 16))  # 1/16 deg steps
    assert r.truth["theta_x"] > 5.0 and abs(r.euler_deg[1] - r.truth["theta_x"]) < 0.5
    assert r.truth["p_0"] < -55.0 and abs(r.truth["p_1"]) < 1e-9
    # the voltage is the divider at the true resistance, within the noise
    assert abs(resistance_from_voltage(r.voltage_V[0]) - r.truth["R_0"]) < 5.0


def test_single_channel_plant_leaves_other_inputs_unconnected():
    plant = make_plant("contractor")
    r = plant.step(0.01, [0, -60, -60], [0, 1, 1], [0, 1, 1])
    assert plant.n_channels == 1 and r.voltage_V[1] == 0.0 and r.voltage_V[2] == 0.0
    assert r.voltage_V[0] == pytest.approx(float(divider_voltage(plant.draws[0].r0_ohm)), abs=2e-3)


def test_reset_reproduces_the_same_noise():
    plant = make_plant("contractor", seed=9)
    first = [plant.step(0.01, [-20, 0, 0], [1, 0, 0], [1, 0, 0]).voltage_V[0] for _ in range(50)]
    plant.reset()
    again = [plant.step(0.01, [-20, 0, 0], [1, 0, 0], [1, 0, 0]).voltage_V[0] for _ in range(50)]
    assert np.array_equal(first, again)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"actuator": "gripper"}, "unknown actuator"),
        ({"actuator": "contractor", "porosity": 95}, "outside 60-90"),
        ({"actuator": "contractor", "load_g": 800}, "outside 0-500"),
        ({"actuator": "contractor", "effects": ["hum"]}, "unknown effect"),
        ({"actuator": "contractor", "effects": {"drift": {"speed": 1}}}, "no parameter"),
    ],
)
def test_invalid_plants_raise_input_errors(kwargs, pattern):
    with pytest.raises(InputError, match=pattern):
        make_plant(**kwargs)


def test_pneumatics_fill_vent_and_flow_limit():
    plant = make_plant("contractor", noise=False)
    p = [plant.step(0.01, [-60, 0, 0], [1, 0, 0], [1, 0, 0]).truth["p_0"] for _ in range(300)]
    assert max(abs(np.diff(p))) <= plant.physics.pneumatics.max_rate_kpa_s * 0.01 + 1e-9
    assert p[-1] == pytest.approx(-60.0, abs=0.1)
    vent = [plant.step(0.01, [-60, 0, 0], [1, 0, 0], [0, 0, 0]).truth["p_0"] for _ in range(100)]
    assert abs(vent[-1]) < 0.5  # vented within 1 s


@pytest.mark.parametrize("phi", (68, 86))
def test_steady_state_matches_a_settled_experiment(phi):
    """The nominal print (no print-to-print variation, no drift, no softening history)."""
    physics = Physics().without("repeat_variation", "baseline_drift", "softening")
    rec = run_experiment("contractor", "step_60", porosity=phi, seed=2, physics=physics)
    ss = steady_state("contractor", porosity=phi, vacuum_kpa=-60, physics=physics)
    assert abs(ss["strain_pct"] - hold_mean(rec, "strain_0", -60)) < 0.5
    # after a 10 s hold the resistance relaxation (3 s mode) has not quite finished
    assert abs(ss["dR_pct"] - hold_mean(rec, "dR_0", -60)) < 1.0
    assert ss["sensitivity"] < 0


def test_steady_state_outputs_of_bending_and_segment():
    bend = steady_state("bending", vacuum_kpa=-60)
    seg = steady_state("3dof", vacuum_kpa=-60)
    assert 5.0 < bend["curvature_per_m"] < 40.0
    assert 8.0 < seg["dz_mm"] < 20.0 and abs(seg["theta_x_deg"]) < 1e-6


def test_segment_tilts_toward_the_active_contractor():
    rec = run_experiment("3dof", "sequential_60", seed=1)
    alone0 = (rec.t > 12) & (rec.t < 15)  # contractor 0 (+y corner) on alone
    alone1 = (rec.t > 32) & (rec.t < 35)  # contractor 1 (210 deg) on alone
    all3 = (rec.t > 132) & (rec.t < 135)
    assert rec["theta_x"][alone0].mean() > 10.0
    assert rec["theta_y"][alone1].mean() > 8.0
    assert abs(rec["theta_x"][all3].mean()) < 1.0 and rec["dz"][all3].mean() > 8.0
