"""An independent resistive strain-sensor generator: not the project's simulator, not its model
structures. For tests that ask whether identification holds on data the engine did not make.

A carbon-black elastomer stretched by a researcher's protocol (ramps, holds, slow cycles, at a
slow logging rate), read as its relative resistance change dR (%). The resistance follows:

- hysteresis: a Prandtl-Ishlinskii sum of play operators (random thresholds and weights) mixed
  with the strain itself, so loading and unloading paths differ by a random amount;
- a saturating piezoresistive map: dR/R0 = -A (1 - exp(-x / x0)) (pores closing) plus a small
  quadratic stiffening term;
- viscoelastic relaxation: the resistance overshoots after every change and relaxes with two
  random time constants (high-pass branches of random signed weight);
- a slow baseline drift over the record, and white measurement noise.

None of these shapes is a Wiener-Hammerstein system, so no model structure is exact; every
parameter is drawn from a wide range by a seeded generator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter


@dataclass
class SensorRecord:
    t: np.ndarray  # s
    dR: np.ndarray  # % (measured, with drift and noise)
    strain: np.ndarray  # % (the truth the model estimates)
    params: dict


def _protocol(rng, n: int, fs: float) -> np.ndarray:
    """Strain (%) of a hand-run protocol: ramps to random levels, holds, and slow cycles."""
    out, level = [], 0.0
    while len(out) < n:
        kind = rng.choice(["ramp_hold", "cycles"], p=[0.65, 0.35])
        if kind == "ramp_hold":
            target = rng.uniform(0.0, 30.0) if level > 5.0 else rng.uniform(5.0, 30.0)
            ramp = max(2, int(rng.uniform(2.0, 20.0) * fs))
            hold = max(1, int(rng.uniform(5.0, 40.0) * fs))
            out += list(np.linspace(level, target, ramp)) + [target] * hold
            level = target
        else:
            period = rng.uniform(4.0, 30.0)
            count = rng.integers(2, 5)
            amp = rng.uniform(2.0, 12.0)
            k = np.arange(int(count * period * fs))
            base = min(max(level, amp), 30.0 - amp)
            seg = base + amp * np.sin(2 * np.pi * k / (period * fs))
            out += list(np.linspace(level, seg[0], max(2, int(2 * fs)))) + list(seg)
            level = float(seg[-1])
    x = np.clip(np.asarray(out[:n]), 0.0, 32.0)
    return lfilter([0.3], [1.0, -0.7], x - x[0]) + x[0]  # the hand and the clamp smooth the corners


def _play(x: np.ndarray, r: float) -> np.ndarray:
    """Play (backlash) operator of half-width ``r``, from rest at x[0]."""
    out = np.empty_like(x)
    y = x[0]
    for i, v in enumerate(x):
        y = min(max(y, v - r), v + r)
        out[i] = y
    return out


def sensor_record(seed: int, n: int = 3400, fs: float = 8.6) -> SensorRecord:
    """One recording of ``n`` samples at ``fs`` Hz with parameters drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    strain = _protocol(rng, n, fs)
    k = int(rng.integers(2, 6))
    thresholds = rng.uniform(0.3, 4.0, k)
    weights = rng.dirichlet(np.ones(k))
    mix = rng.uniform(0.1, 0.6)
    x = (1 - mix) * strain + mix * sum(w * _play(strain, r) for w, r in zip(weights, thresholds))
    amp, x0, stiff = rng.uniform(0.4, 0.9), rng.uniform(6.0, 25.0), rng.uniform(0.0, 0.1)
    rel = -amp * (1 - np.exp(-x / x0)) - stiff * (x / 30.0) ** 2
    taus = np.sort(rng.uniform(1.5, 60.0, 2))
    gains = rng.uniform(0.05, 0.35, 2) * rng.choice([-1.0, 1.0], 2, p=[0.25, 0.75])
    for tau, c in zip(taus, gains):
        a = np.exp(-1.0 / (tau * fs))
        rel = rel + c * lfilter([1.0, -1.0], [1.0, -a], rel - rel[0])  # overshoot, then relaxation
    t = np.arange(n) / fs
    drift = rng.uniform(-0.03, 0.03) * t / t[-1]
    noise = rng.uniform(0.002, 0.01) * np.ptp(rel) * rng.standard_normal(n)
    dR = 100.0 * (rel + drift + noise)
    params = {
        "play_thresholds": thresholds.tolist(),
        "play_weights": weights.tolist(),
        "mix": mix,
        "amplitude": amp,
        "x0": x0,
        "stiffening": stiff,
        "relaxation_s": taus.tolist(),
        "relaxation_gain": gains.tolist(),
        "drift": float(drift[-1]),
    }
    return SensorRecord(t, dR, strain, params)
