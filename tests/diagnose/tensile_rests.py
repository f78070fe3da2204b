"""An independent generator of tensile-test records with rests at zero strain.

Written apart from porosense.diagnose and porosense.sim (it imports neither) to test one rule:
an output that rests at a value by the experiment's design is not clipped there. The physics is
its own: a conductive-elastomer strip is stretched in ramps to a random peak strain, held,
released and left at zero strain between cycles, as labs characterise a strain-sensing
filament. Its resistance change follows the strain through a standard-linear-solid law: an
instantaneous piezoresistive response plus two relaxing branches (time constants drawn from
wide ranges), a small quadratic term, and white measurement noise. The record's output is the
imposed strain (exactly zero during the rests, never below); its input is the resistance change.

Ranges (uniform): sensitivity 0.7-2.7 % dR per % strain, peak strain 5-30 % per cycle, ramps 2-8 s, holds 5-30 s, rests 10-40 s, 4-7 cycles, relaxing shares
10-30 % (fast, tau 1-5 s) and 5-20 % (slow, tau 15-60 s), quadratic bend 0-15 %, noise 0.3-1 % of
the dR span, 10 Hz.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

TS = 0.1  # s


def _strain(rng) -> np.ndarray:
    parts = [np.zeros(int(rng.uniform(5.0, 15.0) / TS))]
    for _ in range(int(rng.integers(4, 8))):
        peak = rng.uniform(5.0, 30.0)
        up, hold, down, rest = (int(rng.uniform(*r) / TS) for r in ((2, 8), (5, 30), (2, 8), (10, 40)))
        parts += [np.linspace(0.0, peak, up), np.full(hold, peak), np.linspace(peak, 0.0, down), np.zeros(rest)]
    return np.concatenate(parts)


def _lag(x: np.ndarray, tau: float) -> np.ndarray:
    a = np.exp(-TS / tau)
    return signal.lfilter([1.0 - a], [1.0, -a], x)


def record(rng, p: dict) -> dict:
    """One record: ``strain`` (%, the output, exactly 0 at rest) and ``dR`` (%, the input)."""
    eps = _strain(rng)
    # a jump with the strain, then two branches relax part of it away while the strain is held;
    # after release the same branches leave the resistance above its rest value for a while
    s = eps - p["share_fast"] * _lag(eps, p["tau_fast"]) - p["share_slow"] * _lag(eps, p["tau_slow"])
    dr = p["gauge"] * (s + p["bend"] * s * s / 30.0)
    dr = dr + rng.normal(0.0, p["noise"] * (np.ptp(dr) or 1.0), len(dr))
    return {"dR": dr, "strain": eps}


def draw(seed: int) -> tuple[dict, dict, dict]:
    """(estimation record, validation record, parameters) of one strip."""
    rng = np.random.default_rng([seed, 4242])
    p = {
        "gauge": rng.uniform(0.7, 2.7),
        "share_fast": rng.uniform(0.1, 0.3),
        "tau_fast": rng.uniform(1.0, 5.0),
        "share_slow": rng.uniform(0.05, 0.2),
        "tau_slow": rng.uniform(15.0, 60.0),
        "bend": rng.uniform(0.0, 0.15),
        "noise": rng.uniform(0.003, 0.01),
    }
    return record(rng, p), record(rng, p), p
