"""Steady state of an actuator at a constant vacuum: stroke and sensitivity for print planning."""

from __future__ import annotations

from porosense.sim import kinematics
from porosense.sim.electronics import divider_voltage
from porosense.sim.foam import load_stress_kpa
from porosense.sim.material import static_dr
from porosense.sim.params import Physics
from porosense.sim.plant import check_actuator, make_plant

_DS_KPA = 0.5  # stress step for the local sensitivity


def steady_state(
    actuator: str, *, porosity=None, load_g: float = 0.0, vacuum_kpa: float = -60.0, physics: Physics | None = None
) -> dict:
    """Settled response of ``actuator`` to a constant chamber vacuum (all channels), for print planning.

    Parameters
    ----------
    actuator : str
        ``"contractor"``, ``"bending"`` or ``"3dof"``.
    porosity : float or None
        Porosity, % (None: the actuator's default).
    load_g : float
        Hanging load, g.
    vacuum_kpa : float
        Chamber gauge pressure, kPa (<= 0; a positive value is read as its magnitude).
    physics : Physics or None
        Stage parameters (print-to-print variation and drift are switched off).

    Returns
    -------
    dict
        ``strain_pct`` (strain of each contractor, % of the unloaded length), ``stroke_pct``
        (relative to the loaded rest, %), ``dR_pct`` (relative to R0 at rest under the load, %),
        ``R_ohm``, ``voltage_V``, ``stress_kpa``, ``sensitivity`` (d dR / d strain, % per %, around
        this point), the actuator's outputs (``curvature_per_m``, or ``theta_x_deg``,
        ``theta_y_deg``, ``dz_mm``) and the inputs.
    """
    check_actuator(actuator)
    physics = (physics or Physics()).without("repeat_variation", "baseline_drift")
    plant = make_plant(actuator, porosity=porosity, load_g=load_g, physics=physics, noise=False)
    ph = plant.physics
    lo, hi = ph.variation.conditioning_range
    softened = 1.0 - ph.piezo.soften_fraction * 0.5 * (lo + hi)
    scale = plant.curve.capacity * ph.piezo.contact_strain
    p = -abs(float(vacuum_kpa))
    sigma_load = float(load_stress_kpa(load_g, ph.foam))
    sigma = -p - sigma_load

    offset = ph.piezo.load_contact_coupling / plant.curve.modulus_kpa * sigma_load

    def dr_of(s):
        eps = plant.static_strains_scalar([s] * plant.n_channels)[0]
        return eps, float(static_dr(eps - offset, ph.piezo, scale, softened))

    eps, g = dr_of(sigma)
    eps_rest, g_rest = dr_of(-sigma_load)
    r = ph.piezo.r0_ohm * (1.0 + g / 100.0)
    r_rest = ph.piezo.r0_ohm * (1.0 + g_rest / 100.0)
    dr = (r - r_rest) / r_rest * 100.0
    e_hi, g_hi = dr_of(sigma + _DS_KPA)
    e_lo, g_lo = dr_of(max(sigma - _DS_KPA, -sigma_load))
    sens = (g_hi - g_lo) / (100.0 * (e_hi - e_lo)) / (1.0 + g_rest / 100.0) if e_hi > e_lo else 0.0
    out = {
        "actuator": actuator,
        "porosity": plant.porosity,
        "load_g": float(load_g),
        "vacuum_kpa": p,
        "stress_kpa": sigma,
        "strain_pct": 100.0 * eps,
        "stroke_pct": 100.0 * (eps - eps_rest),
        "dR_pct": dr,
        "R_ohm": r,
        "voltage_V": float(divider_voltage(r, ph.electronics)),
        "sensitivity": sens,
    }
    if actuator == "bending":
        out["curvature_per_m"] = float(kinematics.bending_curvature(eps, ph.geometry))
    elif actuator == "3dof":
        tx, ty, dz = kinematics.segment_pose([eps] * 3, ph.geometry)
        out.update(theta_x_deg=float(tx), theta_y_deg=float(ty), dz_mm=float(dz))
    return out
