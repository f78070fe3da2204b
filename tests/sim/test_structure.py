"""How far the dR -> strain map is from a Wiener-Hammerstein model.

With the effects beyond WH switched off (porosense.sim.params.PHYSICS_EFFECTS: direction-
dependent contact kinetics, log-domain relaxation, softening) the chain inverts exactly as a
Wiener model (linear relaxation, linear contact lag, static contact curve), which a WH model
contains. With the default physics no WH model is exact: the best one identified on noiseless
records of the paper's experiments leaves a measured share of the signal unexplained.
"""

import numpy as np
from scipy.signal import lfilter

from porosense import ident
from porosense.sim import Physics, make_plant, schedule, steady_state

WH_OFF = ("rate_hysteresis", "log_relaxation", "softening", "baseline_drift")


def _relaxation_inverse(pz, dt):
    """(b, a) of the inverse of dR = g + sum_i k_i (g - LP_i(g)) (two first-order modes)."""
    poles = [np.exp(-dt / tau) for tau in pz.relax_s]
    den = np.array([1.0])
    for a in poles:
        den = np.convolve(den, [1.0, -a])
    num = (1.0 + sum(pz.relax_gain)) * den
    for i, (a, k) in enumerate(zip(poles, pz.relax_gain)):
        other = np.array([1.0])
        for j, b in enumerate(poles):
            if j != i:
                other = np.convolve(other, [1.0, -b])
        num = num - np.pad(k * (1.0 - a) * other, (0, len(den) - len(other)))
    return den, num  # g = lfilter(den, num, dR)


def test_without_the_effects_beyond_wh_the_chain_inverts_exactly():
    plant = make_plant("contractor", porosity=82, noise=False, physics=Physics().without(*WH_OFF))
    pz, dt = plant.draws[0].piezo, 0.01
    scale = plant.curves[0].capacity * pz.contact_strain
    sched = schedule("step_40")  # fast steps: both linear blocks show
    out = plant.run(dt, *sched.actuation(sched.times(1 / dt)))
    dr, strain = out["dR_0"], out["strain_0"] / 100.0
    # 1. undo the network relaxation (linear)
    g = lfilter(*_relaxation_inverse(pz, dt), dr)
    # 2. contacts closed: g = -D x (the softened share is 1 with softening off)
    x = -g / pz.floor_pct
    # 3. undo the contact lag x = r x_eq + (1 - r) LP(x_eq) (linear)
    r, a = pz.instant_share, np.exp(-dt / pz.form_s)
    x_eq = lfilter([1.0, -a], [r + (1.0 - r) * (1.0 - a), -r * a], x)
    # 4. undo the contact curve x_eq = 1 - exp(-(e / scale)^q) (static)
    eps = scale * (-np.log1p(-np.clip(x_eq, 0.0, 1.0 - 1e-15))) ** (1.0 / pz.contact_exponent)
    assert np.max(np.abs(eps - strain)) < 1e-6
    # and both linear blocks matter: skipping either leaves a large error
    x_raw = lfilter([1.0, -a], [r + (1.0 - r) * (1.0 - a), -r * a], -dr / pz.floor_pct)
    skip_relax = scale * (-np.log1p(-np.clip(x_raw, 0.0, 1.0 - 1e-15))) ** (1.0 / pz.contact_exponent)
    skip_lag = scale * (-np.log1p(-np.clip(x, 0.0, 1.0 - 1e-15))) ** (1.0 / pz.contact_exponent)
    assert np.max(np.abs(skip_relax - strain)) > 0.01 and np.max(np.abs(skip_lag - strain)) > 0.01


def _noiseless_paper_records(physics):
    recs = []
    for k, name in enumerate(("staircase", "step_10", "step_60", "step_20", "step_40")):
        plant = make_plant("contractor", porosity=82, noise=False, physics=physics, seed=k)
        sched = schedule(name)
        out = plant.run(0.04, *sched.actuation(sched.times(25.0)))
        recs.append(((out["dR_0"] / 100.0)[:, None], out["strain_0"]))
    return recs


def _wh_fit(physics) -> float:
    recs = _noiseless_paper_records(physics)
    est, val = recs[:3], recs[3:]
    result = ident.search(
        u=[u for u, _ in est],
        y=[y for _, y in est],
        ts=0.04,
        validation=([u for u, _ in val], [y for _, y in val]),
        grid=[("wh", 4, 2)],
        progress=False,
    )
    return result.best_per_structure()["wh"].mean_fit


def test_no_wh_model_is_exact_on_the_default_physics():
    """Noiseless records (no sensor, regulator or camera noise): a WH of 4 poles and 2 zeros
    (above the paper's 2 and 1) fits the chain without the effects beyond WH to within the
    piecewise-linear map's approximation (measured 98.8 %), and misses the default chain by a
    measured share (92.8 %: 6.0 points the physics beyond WH costs a WH model without noise;
    deterministic: noiseless records of fixed seeds)."""
    without = _wh_fit(Physics().without(*WH_OFF, "repeat_variation"))
    default = _wh_fit(Physics())
    print(f"WH 4p2z mean fit on noiseless records: {without:.2f} % without the effects beyond WH, {default:.2f} % with")
    assert without > 98.0
    assert default < without - 5.0


def test_static_map_is_nonlinear():
    """The static dR-strain map saturates as contacts close (the paper's dR beyond -80 % at a
    strain that still grows): the sensitivity between -40 and -60 kPa is under half of the one
    between -10 and -20 kPa (measured 2.7 times lower)."""
    points = [steady_state("contractor", porosity=82, vacuum_kpa=p) for p in (-10, -20, -40, -60)]
    strain = np.array([p["strain_pct"] for p in points])
    dr = np.array([p["dR_pct"] for p in points])
    slopes = np.diff(dr) / np.diff(strain)  # % dR per % strain between the levels
    assert np.all(slopes < 0)
    assert slopes[0] / slopes[-1] > 2.0
