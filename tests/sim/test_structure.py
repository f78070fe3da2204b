"""The dR -> strain map is Wiener-Hammerstein: linear, static pore-collapse curve, linear."""

import numpy as np
from scipy.signal import lfilter

from porosense.sim import make_plant, schedule, steady_state


def test_inverting_the_three_stages_recovers_the_strain():
    plant = make_plant("contractor", porosity=82, noise=False)
    pz, dt = plant.physics.piezo, 0.01
    sched = schedule("step_40")  # fast steps: both linear blocks show
    out = plant.run(dt, *sched.actuation(sched.times(1 / dt)))
    dr, strain = out["dR_0"], out["strain_0"] / 100.0
    # 1. undo the network relaxation dR = g + k (g - LP(g))  (linear)
    a, k = np.exp(-dt / pz.relax_s), pz.relax_gain
    g = lfilter([1.0, -a], [1.0 + k * a, -(1.0 + k) * a], dr)
    # 2. undo the contact curve g = -D (1 - exp(-(eps_c / (capacity n0))^q))  (static)
    x = -np.log1p(np.clip(g, -pz.floor_pct + 1e-12, 0.0) / pz.floor_pct)
    eps_c = plant.curve.capacity * pz.contact_strain * x ** (1.0 / pz.contact_exponent)
    # 3. undo the contact lead-lag (linear)
    r, al = pz.contact_lead_s / pz.contact_lag_s, np.exp(-dt / pz.contact_lag_s)
    eps = lfilter([1.0, -al], [r + (1.0 - r) * (1.0 - al), -r * al], eps_c)
    assert np.max(np.abs(eps - strain)) < 1e-6
    # and both linear blocks matter: skipping either leaves a large error
    assert np.max(np.abs(eps_c - strain)) > 0.01
    x_raw = -np.log1p(np.clip(dr, -pz.floor_pct + 1e-12, 0.0) / pz.floor_pct)
    eps_raw = plant.curve.capacity * pz.contact_strain * x_raw ** (1.0 / pz.contact_exponent)
    assert np.max(np.abs(lfilter([1.0, -al], [r + (1.0 - r) * (1.0 - al), -r * al], eps_raw) - strain)) > 0.01


def test_static_map_is_nonlinear():
    points = [steady_state("contractor", porosity=82, vacuum_kpa=p) for p in (-10, -20, -40, -60)]
    strain = np.array([p["strain_pct"] for p in points])
    dr = np.array([p["dR_pct"] for p in points])
    slopes = np.diff(dr) / np.diff(strain)  # % dR per % strain between the levels
    assert np.all(slopes < 0)
    assert slopes[0] / slopes[-1] > 3.0  # pore collapse: sensitivity falls as contacts saturate
