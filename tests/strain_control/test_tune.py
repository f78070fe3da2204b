"""Plant identification and tuning: FOPDT recovery from an independent generator, the lambda
rule against its formula, the predicted step against the closed-loop analytic response, and
the tuned plant against the simulator's own open-loop response."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from porosense.control import fit_fopdt, lambda_pi, predict_step, static_map
from porosense.control.plant import Fopdt
from porosense.errors import InputError


def _continuous_fopdt(K, T, theta, ts, v, rng, noise):
    """K e^(-theta s) / (T s + 1) driven by the held command ``v``, simulated on a grid 20x finer
    than ts with scipy's continuous-time lsim (not the discrete model the fit uses)."""
    fine = 20
    tf = np.arange(len(v) * fine) * (ts / fine)
    u = np.repeat(v, fine)
    shift = int(round(theta / (ts / fine)))
    u = np.concatenate([np.zeros(shift), u[: len(u) - shift]])
    _, y, _ = signal.lsim(signal.lti([K], [T, 1.0]), u, tf)
    return y[::fine] + rng.normal(0.0, noise, len(v))


def test_fopdt_fit_recovers_random_plants():
    rng = np.random.default_rng(17)
    worst = {"K": 0.0, "T": 0.0, "theta_samples": 0.0}
    for _ in range(8):
        K, T, ts = rng.uniform(0.05, 3.0), rng.uniform(0.05, 3.0), rng.choice([0.01, 0.02, 0.05])
        theta = rng.uniform(0.0, 0.5)
        recs_v, recs_y = [], []
        for _ in range(2):
            hold = max(int(4 * T / ts), 20)
            v = np.repeat(rng.uniform(0, 60, 8) * (rng.random(8) > 0.2), hold)
            y = _continuous_fopdt(K, T, theta, ts, v, rng, noise=0.01 * K * 60)
            recs_v.append(v)
            recs_y.append(y + rng.uniform(-3, 3))  # an offset per recording (e.g. a load's stretch)
        p = fit_fopdt(recs_v, recs_y, ts)
        worst["K"] = max(worst["K"], abs(p.K / K - 1))
        worst["T"] = max(worst["T"], abs(p.T / T - 1))
        # ZOH sampling: the fitted dead time is the true one to within about one sample
        worst["theta_samples"] = max(worst["theta_samples"], abs(p.theta + ts / 2 - theta) / ts)
    print("worst relative errors:", worst)
    assert worst["K"] < 0.03 and worst["T"] < 0.10 and worst["theta_samples"] <= 1.0


def test_lambda_rule_matches_its_formula():
    rng = np.random.default_rng(3)
    for _ in range(20):
        K, T, ts = rng.uniform(0.01, 5), rng.uniform(0.01, 10), rng.uniform(0.001, 0.1)
        d = int(rng.integers(0, 30))
        lam, slew = rng.uniform(0.01, 10), rng.uniform(0.1, 50)
        g = lambda_pi(Fopdt(K, T, d * ts, ts), lam, slew)
        kp = T / (K * (lam + d * ts + ts / 2))
        assert g.kp_kpa == pytest.approx(kp, rel=1e-12)
        assert g.ki_kpa_per_s == pytest.approx(kp / T, rel=1e-12)
        assert g.slew_per_s == slew


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_lambda_rule_refuses_a_bad_tau(bad):
    with pytest.raises(InputError):
        lambda_pi(Fopdt(1.0, 1.0, 0.0, 0.01), bad, 1.0)


def test_predicted_step_settles_like_the_first_order_loop_the_rule_aims_at():
    # Without dead time and with a fast sample, lambda tuning cancels the plant pole: the loop
    # is first order with time constant lam + Ts/2, so the 2 % settling time is ln(50) of it.
    for K, T, lam in ((0.45, 0.3, 0.3), (2.0, 1.5, 0.5), (0.1, 0.05, 1.0)):
        ts = 0.001
        p = Fopdt(K, T, 0.0, ts)
        pred = predict_step(p, lambda_pi(p, lam, 1e6), 10.0)
        expected = math.log(50) * (lam + ts / 2)
        assert pred.settling_s == pytest.approx(expected, rel=0.03)
        assert pred.overshoot_pct < 0.5


def test_tuned_plant_predicts_the_simulator_open_loop_step():
    """Fit on the paper's recordings at 0 g, predict a held-out step of the simulator (another
    seed and level): the FOPDT simulation matches it to a fit of at least 85 % (measured 88 %)."""
    from porosense.ident import fit_percent
    from porosense.sim import run_experiment

    recs = [
        run_experiment("contractor", e, rate_hz=50, seed=s)
        for s, e in enumerate(("staircase", "step_10", "step_20", "step_60"))
    ]
    p = fit_fopdt([-r["p_cmd_0"] for r in recs], [r["strain_0"] for r in recs], 0.02)
    held = run_experiment("contractor", "step_40", rate_hz=50, seed=11)
    fit = fit_percent(held["strain_0"], p.simulate(-held["p_cmd_0"]))
    print(f"FOPDT on a held-out -40 kPa step: fit {fit:.1f} %; {p}")
    assert fit > 85.0
    assert 0.1 < p.T < 1.0 and p.theta <= 0.1


def test_static_map_inverts_the_simulator_steady_state():
    """The map measured from holds every 5 kPa gives a vacuum whose steady strain (the
    simulator's own steady-state solution of the nominal print, independent of the recordings)
    is within 0.6 % strain: measured 0.40 (0.04 before prints varied: the recorded print's foam
    is drawn a few percent stiffer or softer than the nominal one, porosense.sim.variation)."""
    from porosense.control.loadbench import measure_static_map
    from porosense.sim.steady import steady_state

    smap = measure_static_map(50, seed=5)
    worst = 0.0
    for target in (3.0, 7.5, 12.0, 18.0, 24.0):
        v = float(smap.vacuum_for(target))
        worst = max(worst, abs(steady_state("contractor", vacuum_kpa=-v)["strain_pct"] - target))
    print(f"static map: worst steady-state miss {worst:.3f} % strain")
    assert worst < 0.6


def test_static_map_needs_two_levels():
    t = np.arange(500) * 0.02
    with pytest.raises(InputError):
        static_map([(t, np.zeros(500), np.zeros(500))])
