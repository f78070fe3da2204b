"""Random stable WH structures with realistic poles (near z = 1 at 50 Hz) and test inputs,
for the fixed-point tests, the bit-exactness vectors and the benchmark."""

from __future__ import annotations

import numpy as np
from scipy import signal

from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade


def random_cascade(rng: np.random.Generator, n_poles: int, slow: float = 0.999, gain: float = 1.0) -> SOSCascade:
    """Stable cascade of ``n_poles`` poles (radius 0.9..slow, some complex with small angles),
    fewer zeros, and the given DC gain."""
    poles: list[complex] = []
    zeros: list[complex] = []
    while len(poles) < n_poles:
        r = 1.0 - 10 ** rng.uniform(np.log10(1 - slow), -1)
        if n_poles - len(poles) >= 2 and rng.random() < 0.4:
            th = rng.uniform(0.005, 0.2)
            poles += [r * np.exp(1j * th), r * np.exp(-1j * th)]
        else:
            poles.append(r)
    for _ in range(int(rng.integers(0, n_poles))):
        zeros.append(rng.uniform(-0.5, 0.98))
    z = np.array(zeros, dtype=complex)
    p = np.array(poles, dtype=complex)
    # From roots, not polynomials: expanding 10 poles near 1 loses them.
    k = gain * float(np.real(np.prod(1 - p) / np.prod(1 - z)))
    z = np.concatenate([z, np.zeros(len(p) - len(z))])
    return SOSCascade(signal.zpk2sos(z, p, k, pairing="nearest"))


def random_pwl(rng: np.random.Generator, n: int, lo: float, hi: float, gain: float = 1.0) -> PiecewiseLinear:
    """Monotone-ish table over [lo, hi] with slopes around ``gain``."""
    x = np.sort(rng.uniform(lo, hi, n))
    x = np.linspace(lo, hi, n) + 0.2 * (x - np.linspace(lo, hi, n))
    slopes = gain * rng.uniform(0.3, 1.7, n - 1)
    y = np.concatenate([[gain * x[0]], gain * x[0] + np.cumsum(slopes * np.diff(x))])
    return PiecewiseLinear(x, y)


def random_structure(
    rng: np.random.Generator,
    n_inputs: int = 1,
    n_outputs: int = 1,
    *,
    h1_poles: int = 4,
    h2_poles: int = 2,
    breakpoints: int = 10,
    kind: str = "wh",
    slow: float = 0.999,
) -> EstimatorStructure:
    """A random structure of ``kind`` linear | hammerstein | wiener | wh, inputs dR in %."""
    outputs = []
    for j in range(n_outputs):
        branches = []
        for i in range(n_inputs):
            f = random_pwl(rng, breakpoints, -90, 10, 1.0) if kind in ("hammerstein", "wh") else None
            h1 = random_cascade(rng, h1_poles, slow, gain=rng.uniform(-0.4, -0.1))
            branches.append(
                Branch(input=i, h1=h1, f=f, delay=int(rng.integers(0, 4)), u_offset=float(rng.uniform(-2, 2)))
            )
        g = random_pwl(rng, breakpoints, -40, 40, 1.0) if kind in ("wiener", "wh") else None
        h2 = random_cascade(rng, h2_poles, slow) if kind == "wh" and h2_poles else None
        outputs.append(
            OutputChain(name=f"y{j}", branches=tuple(branches), g=g, h2=h2, offset=float(rng.uniform(-1, 1)))
        )
    return EstimatorStructure(
        inputs=tuple(f"dR_{i}" for i in range(n_inputs)), outputs=tuple(outputs), ts=0.02, meta={"kind": kind}
    )


def step_inputs(
    rng: np.random.Generator, n: int, n_inputs: int = 1, lo: float = -85.0, hi: float = 5.0, hold: int = 500
) -> np.ndarray:
    """Smoothed random steps inside [lo, hi] (dR in %), shape (n, n_inputs): the paper's
    on/off vacuum steps seen through the sensor."""
    u = np.empty((n, n_inputs))
    for i in range(n_inputs):
        levels = rng.uniform(lo, hi, n // hold + 2)
        raw = np.repeat(levels, hold)[:n]
        alpha = 0.05
        sm = np.empty(n)
        acc = raw[0]
        for t in range(n):
            acc += alpha * (raw[t] - acc)
            sm[t] = acc
        u[:, i] = sm + rng.normal(0, 0.05, n)
    return u
