"""Filter banks and hysteresis operators of the model extensions.

Both act on one record at a time (a 1-D array sampled at a constant rate), so that each starts
afresh at the beginning of every record.
"""

from __future__ import annotations

import numpy as np
from scipy import signal


def laguerre_bank(x, pole: float, order: int, *, settled: bool = False) -> np.ndarray:
    """Outputs of a discrete Laguerre filter bank.

    The first filter is sqrt(1 - a^2) / (1 - a q^-1); each next one multiplies by the all-pass
    (q^-1 - a) / (1 - a q^-1). Any stable linear response dominated by time constants near
    -ts / ln(a) is a short linear combination of the outputs.

    Parameters
    ----------
    x : array_like, (N,)
        The input (any unit).
    pole : float
        The real pole a, 0 <= a < 1 (a = exp(-ts / tau) for a time constant tau).
    order : int
        Number of filters.
    settled : bool
        False: every filter starts from rest. True: every filter starts in steady state at x[0]
        (a record that begins at rest on a non-zero input).

    Returns
    -------
    numpy.ndarray, (N, order)
        One column per filter, in the unit of ``x``.
    """
    x = np.asarray(x, dtype=float)
    a = float(pole)
    out = np.empty((len(x), order))
    cur = signal.lfilter([np.sqrt(1.0 - a * a)], [1.0, -a], x - x[0] if settled else x)
    for k in range(order):
        out[:, k] = cur
        if k + 1 < order:
            cur = signal.lfilter([-a, 1.0], [1.0, -a], cur)
    if settled:
        # Every all-pass stage has unit DC gain: each filter's steady state is the first's.
        out += x[0] * np.sqrt(1.0 - a * a) / (1.0 - a)
    return out


def play_operator(x, radius: float) -> np.ndarray:
    """Play (backlash) operator of half-width ``radius``, starting centred on x[0].

    The output follows x only after x has moved ``radius`` in the new direction: the elementary
    rate-independent hysteresis (the Prandtl-Ishlinskii building block).

    Parameters
    ----------
    x : array_like, (N,)
        The input (any unit).
    radius : float
        Half-width of the play, in the unit of ``x`` (>= 0).

    Returns
    -------
    numpy.ndarray, (N,)
        The operator's output, in the unit of ``x``.
    """
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    z = float(x[0]) if len(x) else 0.0
    r = float(radius)
    for k, xk in enumerate(x.tolist()):
        if xk - z > r:
            z = xk - r
        elif z - xk > r:
            z = xk + r
        out[k] = z
    return out
