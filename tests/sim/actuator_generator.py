"""An independent generator of a soft vacuum contractor's recordings (written apart from
porosense.sim and sharing none of its equations), for calibration tests.

Physics: the chamber pressure follows the command through a first-order lag. The static
strain is ``e_max (1 - exp(-(|p| / p0)^m))`` and the strain follows it as a Kelvin-Voigt
element (one time constant). The resistance follows a Hill function of the strain,
``dR = -D e^b / (e^b + K^b)``, through a first-order lag, and relaxes in ln R: a high-pass of
ln(1 + dR/100) of gain ``k`` and time constant ``tr`` (an overshoot after each release).
Measurement noise on dR and on the strain. Every parameter is drawn from a wide range; the
commands are the paper's schedules (porosense.sim.schedule: timings, not physics).

A hanging load (optional, :func:`draw_load`): the load L (g) opposes the vacuum, scaling the
static contraction by ``1 - k_L L`` (10-30 % less at 500 g, the range the diagnosis trials
state, porosense.diagnose.trials), lengthens the actuator by ``s_L L`` (a linear spring in
series, no lag) and opens contacts, raising ln R by ``r_L L`` (no lag); the contraction the
Hill function sees is ``max(e - s_L L, 0)``.
"""

from __future__ import annotations

import numpy as np


def draw(rng) -> dict:
    return {
        "tau_p": rng.uniform(0.1, 0.5),
        "e_max": rng.uniform(0.15, 0.35),
        "p0": rng.uniform(15.0, 40.0),
        "m": rng.uniform(1.0, 2.5),
        "tau_e": rng.uniform(0.1, 0.8),
        "D": rng.uniform(80.0, 98.0),
        "K": rng.uniform(0.05, 0.2),
        "b": rng.uniform(1.0, 2.5),
        "tau_c": rng.uniform(0.2, 1.5),
        "k": rng.uniform(0.0, 0.15),
        "tr": rng.uniform(1.0, 5.0),
    }


def _lag(u, dt, tau, y0=0.0):
    a = np.exp(-dt / tau)
    y, out = y0, np.empty_like(u)
    for n, x in enumerate(u):
        y = a * y + (1.0 - a) * x
        out[n] = y
    return out


def draw_load(rng) -> dict:
    """Load sensitivities per g: contraction lost ``k_L`` (10-30 % at 500 g), lengthening ``s_L``
    (fraction; 1-5 % at 500 g) and ln R rise ``r_L`` (0.02-0.10 at 500 g)."""
    return {
        "k_L": rng.uniform(0.10, 0.30) / 500.0,
        "s_L": rng.uniform(0.01, 0.05) / 500.0,
        "r_L": rng.uniform(0.02, 0.10) / 500.0,
    }


def record(rng, par: dict, p_cmd: np.ndarray, rate_hz: float, load_g=None, load_par=None) -> dict:
    """dR (%) and strain (%) for a commanded vacuum series (kPa, <= 0) at ``rate_hz``; with
    ``load_g`` (N,) g and ``load_par`` (:func:`draw_load`) under that hanging load."""
    dt = 1.0 / rate_hz
    p = _lag(np.asarray(p_cmd, dtype=float), dt, par["tau_p"])
    e_s = par["e_max"] * -np.expm1(-((np.abs(p) / par["p0"]) ** par["m"]))
    load = np.zeros(e_s.size) if load_g is None else np.asarray(load_g, dtype=float)
    if load_g is not None:
        e_s = e_s * (1.0 - load_par["k_L"] * load)
    e = _lag(e_s, dt, par["tau_e"])
    if load_g is not None:
        e = e - load_par["s_L"] * load
    ec = np.maximum(e, 0.0)
    hill = ec ** par["b"] / (ec ** par["b"] + par["K"] ** par["b"])
    c = _lag(hill, dt, par["tau_c"])
    h = np.log1p(-par["D"] / 100.0 * c) + (0.0 if load_g is None else load_par["r_L"] * load)
    lnr = h + par["k"] * (h - _lag(h, dt, par["tr"]))
    dr = 100.0 * np.expm1(lnr) + 0.2 * rng.standard_normal(e.size)
    strain = 100.0 * e + 0.2 * rng.standard_normal(e.size)
    return {"dR_0": dr, "strain_0": strain, "p_cmd_0": np.asarray(p_cmd, dtype=float)}
