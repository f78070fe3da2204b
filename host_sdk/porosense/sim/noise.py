"""Random processes of the plant: first-order (Ornstein-Uhlenbeck) noise and random walks.

Both come in two forms that share their statistics: a stepper drawing one sample at a time
from a source of standard normals (the emulator and the simboard step the plant) and a
vectorised series (``Plant.run``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter


class NormalBank:
    """Pre-drawn standard normals and uniforms, handed out one at a time (cheap per step)."""

    def __init__(self, rng: np.random.Generator, block: int = 4096):
        self.rng, self.block = rng, block
        self._n, self._u, self.i, self.j = [], [], 0, 0

    def normal(self) -> float:
        if self.i >= len(self._n):
            self._n, self.i = self.rng.standard_normal(self.block).tolist(), 0
        self.i += 1
        return self._n[self.i - 1]

    def uniform(self) -> float:
        if self.j >= len(self._u):
            self._u, self.j = self.rng.random(self.block).tolist(), 0
        self.j += 1
        return self._u[self.j - 1]


def ou_coefficients(dt: float, sigma: float, tau: float) -> tuple[float, float]:
    """(a, b) of ``y[k] = a y[k-1] + b w[k]`` (w standard normal): stationary rms ``sigma``,
    correlation time ``tau`` (s), sample period ``dt`` (s)."""
    a = math.exp(-dt / tau) if tau > 0 else 0.0
    return a, sigma * math.sqrt(max(1.0 - a * a, 0.0))


def ou_series(rng: np.random.Generator, n: int, dt: float, sigma: float, tau: float, shape=()) -> np.ndarray:
    """(n, *shape) samples of a stationary first-order noise (rms ``sigma``, time constant ``tau`` s)."""
    if sigma <= 0.0 or n == 0:
        return np.zeros((n, *shape))
    a, b = ou_coefficients(dt, sigma, tau)
    w = rng.standard_normal((n, *shape))
    y0 = sigma * rng.standard_normal(shape)
    return lfilter([b], [1.0, -a], w, axis=0, zi=np.asarray(a * y0)[None, ...])[0]


def walk_series(rng: np.random.Generator, n: int, dt: float, rms_per_min: float, shape=()) -> np.ndarray:
    """(n, *shape) random walk from 0 with ``rms_per_min`` of spread after 60 s."""
    if rms_per_min <= 0.0 or n == 0:
        return np.zeros((n, *shape))
    return np.cumsum(rng.standard_normal((n, *shape)) * rms_per_min * math.sqrt(dt / 60.0), axis=0)
