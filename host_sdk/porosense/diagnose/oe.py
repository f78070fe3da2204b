"""A small output-error (OE) fitter: the cheap linear baseline diagnosis can start from.

y[k] = c + sum_i B_i(q) / F_i(q) u_i[k - delay], fitted on the simulation error over several
records (each simulated from rest), initialised by ARX least squares and refined with
scipy.optimize.least_squares. It exists so that diagnosis and its tests do not need the full
identification engine for a low-order linear reference; ``porosense.ident`` remains the tool
for real identification.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from porosense.diagnose import signals
from porosense.errors import ModelError


def _stabilise(f: np.ndarray) -> np.ndarray:
    """Reflect roots of the monic denominator f outside the unit circle back inside."""
    if len(f) <= 1:
        return f
    r = np.roots(f)
    if np.all(np.abs(r) < 1.0):
        return f
    r = np.where(np.abs(r) >= 1.0, 0.99 / np.conj(r), r)
    return np.real(np.poly(r))


@dataclass
class OEModel:
    """MISO output-error model: b[i] (nb,), f[i] monic (nf + 1,), offset, input delay (samples)."""

    b: list
    f: list
    offset: float
    delay: int = 0

    @property
    def n_inputs(self) -> int:
        return len(self.b)

    def predict(self, u: np.ndarray) -> np.ndarray:
        """Simulation for u (N, n_inputs) settled at its rest level (:func:`.signals.rest_level`); returns (N,)."""
        u = np.asarray(u, float).reshape(len(u), -1)
        y = np.full(len(u), self.offset)
        for i in range(self.n_inputs):
            x = u[:, i]
            # start settled at the record's rest level (its first value when it starts on a hold)
            x0 = signals.rest_level(x)
            if self.delay:
                x = np.concatenate([np.full(self.delay, x0), x[: len(x) - self.delay]])
            dc = np.sum(self.b[i]) / np.sum(self.f[i])
            y += signal.lfilter(self.b[i], self.f[i], x - x0) + dc * x0
        return y

    def to_dict(self) -> dict:
        return {
            "b": [list(map(float, b)) for b in self.b],
            "f": [list(map(float, f)) for f in self.f],
            "offset": float(self.offset),
            "delay": int(self.delay),
        }


def fit_oe(
    u_list: list, y_list: list, n_poles: int = 2, n_zeros: int = 1, delay: int = 0, loss: str = "linear"
) -> OEModel:
    """Fit an OE model with ``n_poles`` poles and ``n_zeros`` zeros per input (b0 included).

    u_list: arrays (N_r, n_inputs); y_list: arrays (N_r,); loss as in least_squares
    ("linear" = least squares, "huber" = robust to outliers).
    """
    us = [np.asarray(u, float).reshape(len(u), -1) for u in u_list]
    ys = [np.asarray(y, float) for y in y_list]
    if not us or any(len(u) != len(y) for u, y in zip(us, ys)):
        raise ModelError("fit_oe needs matching input and output records")
    n_in = us[0].shape[1]
    nb, nf = n_zeros + 1, n_poles
    # ARX initialisation with a common denominator
    rows, targets = [], []
    p = max(nf, nb + delay)
    for u, y in zip(us, ys):
        for k in range(p, len(y)):
            reg = [-y[k - j] for j in range(1, nf + 1)]
            for i in range(n_in):
                reg += [u[k - delay - j, i] for j in range(nb)]
            rows.append(reg + [1.0])
            targets.append(y[k])
    th, *_ = np.linalg.lstsq(np.asarray(rows), np.asarray(targets), rcond=None)
    a = _stabilise(np.concatenate([[1.0], th[:nf]]))
    b0 = [th[nf + i * nb : nf + (i + 1) * nb] for i in range(n_in)]

    def unpack(theta):
        b, f = [], []
        k = 0
        for _ in range(n_in):
            b.append(theta[k : k + nb])
            k += nb
            f.append(np.concatenate([[1.0], theta[k : k + nf]]))
            k += nf
        return b, f, theta[k]

    def model(theta):
        b, f, c = unpack(theta)
        return OEModel(b, [_stabilise(fi) for fi in f], c, delay)

    def residuals(theta):
        m = model(theta)
        return np.concatenate([m.predict(u) - y for u, y in zip(us, ys)])

    theta0 = []
    for i in range(n_in):
        theta0 += list(b0[i]) + list(a[1:])
    theta0.append(0.0)
    theta0 = np.asarray(theta0, float)
    # offset initial guess: mean error of the ARX-initialised simulation
    theta0[-1] = -float(np.mean(residuals(theta0)))
    scale = np.std(np.concatenate(ys)) or 1.0
    sol = optimize.least_squares(
        residuals, theta0, loss=loss, f_scale=scale * 0.1, method="trf", x_scale="jac", max_nfev=60 * len(theta0)
    )
    return model(sol.x)
