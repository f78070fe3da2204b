"""An independent generator of tensile tests of a carbon-black elastomer (written apart from
porosense.sim and sharing none of its equations), for calibration tests.

Physics: the strain program is ramps to random levels with holds and rests. The filler network
feels an effective strain that relaxes at constant strain (two Maxwell arms: the network
re-forms under load, ``e_net = e - w1 q1 - w2 q2`` with ``dq/dt = (e - q) / tau``). The
inter-particle gap grows with it and the tunnelling resistance follows Simmons' law,
``R = R0 (1 + c e_net) exp(k c e_net)``; the largest strain seen so far raises R for good
(damage, ``m``). R0 differs between recordings and drifts linearly within one; the noise is
multiplicative (white and a slow first-order part). Every parameter is drawn from a wide range.
"""

from __future__ import annotations

import numpy as np


def strain_program(rng, rate_hz: float, n_cycles: int) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and strain (fraction): rest, then ramps to 5-40 % at 0.5-3 %/s, holds of
    20-90 s, ramps back to 0-30 % of the level, rests of 15-45 s."""
    pieces = [np.zeros(int(10 * rate_hz))]
    level = 0.0
    for _ in range(n_cycles):
        top = rng.uniform(0.05, 0.40)
        speed = rng.uniform(0.005, 0.03)
        ramp = np.linspace(level, top, max(2, int(abs(top - level) / speed * rate_hz)))
        hold = np.full(int(rng.uniform(20, 90) * rate_hz), top)
        low = top * rng.uniform(0.0, 0.3)
        down = np.linspace(top, low, max(2, int((top - low) / speed * rate_hz)))
        rest = np.full(int(rng.uniform(15, 45) * rate_hz), low)
        pieces += [ramp, hold, down, rest]
        level = low
    e = np.concatenate(pieces)
    return np.arange(e.size) / rate_hz, e


def draw_material(rng) -> dict:
    return {
        "c": rng.uniform(0.5, 2.0),
        "k": rng.uniform(2.0, 6.0),
        "tau": (rng.uniform(2.0, 10.0), rng.uniform(30.0, 200.0)),
        "w": (rng.uniform(0.05, 0.2), rng.uniform(0.05, 0.2)),
        "m": rng.uniform(0.0, 0.1),
    }


def record(rng, material: dict, *, rate_hz: float = 10.0, n_cycles: int = 4, r0_ohm: float = 1e4) -> dict:
    """One recording: t (s), strain (fraction), R (ohm), and the R0 and drift it was drawn with."""
    t, e = strain_program(rng, rate_hz, n_cycles)
    dt = 1.0 / rate_hz
    q = np.zeros((2, e.size))
    for i, (tau, _) in enumerate(zip(material["tau"], material["w"])):
        a = np.exp(-dt / tau)
        y = 0.0
        for n, x in enumerate(e):
            y = a * y + (1.0 - a) * x
            q[i, n] = y
    e_net = e - material["w"][0] * q[0] - material["w"][1] * q[1]
    c, k = material["c"], material["k"]
    damage = 1.0 + material["m"] * np.maximum.accumulate(e)
    r0 = r0_ohm * rng.uniform(0.7, 1.3)
    drift = rng.uniform(-0.5, 0.5)  # % of R0 per minute
    slow = np.zeros(e.size)
    a = np.exp(-dt / 5.0)
    w = rng.standard_normal(e.size) * 0.002 * np.sqrt(1 - a * a)
    for n in range(1, e.size):
        slow[n] = a * slow[n - 1] + w[n]
    noise = 1.0 + 0.002 * rng.standard_normal(e.size) + slow
    r = r0 * (1.0 + drift * t / 6000.0) * damage * (1.0 + c * e_net) * np.exp(k * c * e_net) * noise
    return {"t": t, "strain": e, "R": r, "r0_ohm": r0, "drift_pct_per_min": drift}
