"""The block chain every model is a special case of, its simulation and its exact Jacobian.

One output over n inputs (all in normalised units inside ident)::

    y = offset + H2( g( sum_i B_i/F_i ( f_i( u_i[k - delay] ) ) ) )

Blocks are switched on by :class:`ChainSpec`. The Jacobian of the simulated output with
respect to every parameter is computed with filtered sensitivity signals (lfilter): for
w = B/F v, dw/db_k = q^-k v/F and dw/da_k = -q^-k w/F; upstream sensitivities pass through
the downstream blocks (times g'(s), then through H2). Denominators are cascades of stable
sections (:mod:`porosense.ident.blocks`); for a section F_s, dw/da_(s,j) = -q^-j w/F_s.
Everything simulates from rest.

Process noise (``g_noise``): a Gaussian v of standard deviation sigma = exp(theta["g.s"]) adds
to g's input, so the expected output is y = offset + H2(E_v g(s + v)) (closed form for a
piecewise-linear g, :func:`blocks.pwl_expected`). Estimation fits that expectation; the
noise-free system (g itself) is what ``simulate(u, expected=False)`` returns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from porosense.ident import blocks


@dataclass(frozen=True)
class ChainSpec:
    """Which blocks exist and their sizes. ``f_bp``/``g_bp`` = 0 means no f/g."""

    n_inputs: int
    np1: int
    nz1: int
    f_bp: int = 0
    g_bp: int = 0
    h2: bool = False
    np2: int = 0
    nz2: int = 0
    delay: int = 0
    g_noise: bool = False

    def sizes(self) -> list[tuple[str, int]]:
        """Ordered (name, length) of the parameter groups."""
        out = []
        for i in range(self.n_inputs):
            if self.f_bp:
                out += [(f"f{i}.p", self.f_bp), (f"f{i}.y", self.f_bp)]
            out += [(f"h1{i}.a", self.np1), (f"h1{i}.b", self.nz1 + 1)]
        if self.g_bp:
            out += [("g.p", self.g_bp), ("g.y", self.g_bp)]
            if self.g_noise:
                out += [("g.s", 1)]
        if self.h2:
            out += [("h2.a", self.np2), ("h2.b", self.nz2 + 1)]
        out += [("offset", 1)]
        return out

    def slices(self) -> dict[str, slice]:
        pos, out = 0, {}
        for name, n in self.sizes():
            out[name] = slice(pos, pos + n)
            pos += n
        return out

    @property
    def n_params(self) -> int:
        return sum(n for _, n in self.sizes())


def _shift(x, k: int):
    """Delay by k samples from rest along axis 0."""
    if k == 0:
        return x
    out = np.zeros_like(x)
    out[k:] = x[:-k]
    return out


def _filter(b, den, x):
    """B(q) / prod F_s(q) applied to ``x`` (1-D, or 2-D along axis 0) from rest."""
    return blocks.cascade(den, lfilter(b, [1.0], x, axis=0))


def _den_sensitivity(den, dden, w, n_poles):
    """dw/dtheta (N, n_poles) of w = B/F v with respect to the denominator parameters."""
    out = np.zeros((len(w), n_poles))
    for s, row in enumerate(den):
        ws = lfilter([1.0], row, w)
        cols = -np.column_stack([_shift(ws, 1), _shift(ws, 2)])
        j = slice(2 * s, min(2 * s + 2, n_poles))
        out[:, j] = cols @ dden[s][:, : j.stop - j.start]
    return out


def _lagged(x, n: int, start: int = 0):
    """Columns q^-start x .. q^-(start+n-1) x, shape (N, n)."""
    out = np.zeros((len(x), n))
    for k in range(n):
        out[:, k] = _shift(x, start + k)
    return out


class Chain:
    """Decoded parameters of a :class:`ChainSpec`; ``simulate`` and ``jacobian`` on inputs."""

    def __init__(self, spec: ChainSpec, theta):
        self.spec = spec
        self.theta = np.asarray(theta, dtype=float)
        sl = spec.slices()
        self.sl = sl
        t = self.theta
        self.f = []
        self.h1 = []
        for i in range(spec.n_inputs):
            if spec.f_bp:
                x, dx = blocks.pwl_positions(t[sl[f"f{i}.p"]])
                self.f.append((x, t[sl[f"f{i}.y"]], dx))
            else:
                self.f.append(None)
            den, dden = blocks.sections(t[sl[f"h1{i}.a"]])
            self.h1.append((t[sl[f"h1{i}.b"]], den, dden))
        self.g = None
        if spec.g_bp:
            x, dx = blocks.pwl_positions(t[sl["g.p"]])
            self.g = (x, t[sl["g.y"]], dx)
        # Standard deviation of the process noise at g's input (normalised units), or 0.
        self.g_sigma = float(np.exp(np.clip(t[sl["g.s"]][0], -30.0, 30.0))) if spec.g_noise else 0.0
        self.h2 = None
        if spec.h2:
            den, dden = blocks.sections(t[sl["h2.a"]])
            self.h2 = (t[sl["h2.b"]], den, dden)
        self.offset = float(t[sl["offset"]][0])

    # -- forward ------------------------------------------------------------------

    def branch_inputs(self, u):
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        return [_shift(u[:, i].copy(), self.spec.delay) for i in range(self.spec.n_inputs)]

    def simulate(self, u, expected: bool = True) -> np.ndarray:
        """Output from rest for inputs ``u`` (N, n_inputs), normalised units.

        With process noise in the spec: its expectation over the noise (``expected``, what the
        estimation fits), or the noise-free system (``expected=False``)."""
        s = self.linear_sum(u)
        if self.g and self.g_sigma > 0 and expected:
            z = blocks.pwl_expected(self.g[0], self.g[1], s, self.g_sigma)
        else:
            z = blocks.pwl_eval(self.g[0], self.g[1], s) if self.g else s
        if self.h2:
            b, den, _ = self.h2
            z = _filter(b, den, z)
        return z + self.offset

    def linear_sum(self, u) -> np.ndarray:
        """s = sum_i H1_i(f_i(u_i)), the signal entering g."""
        xs = self.branch_inputs(u)
        s = np.zeros(len(xs[0]))
        for i, x in enumerate(xs):
            if self.f[i] is not None:
                x = blocks.pwl_eval(self.f[i][0], self.f[i][1], x)
            b, den, _ = self.h1[i]
            s += _filter(b, den, x)
        return s

    # -- Jacobian -----------------------------------------------------------------

    def jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """(y, dy/dtheta) with dy/dtheta of shape (N, n_params)."""
        spec, sl = self.spec, self.sl
        xs = self.branch_inputs(u)
        n = len(xs[0])
        jac = np.zeros((n, spec.n_params))
        s = np.zeros(n)
        # Columns that pass through g and H2 are collected first (sensitivities of s).
        for i, x in enumerate(xs):
            b, den, dden = self.h1[i]
            if self.f[i] is not None:
                fx, fy, dxdp = self.f[i]
                v, _, dz_dx, dz_dy = blocks.pwl_eval(fx, fy, x, derivatives=True)
                jac[:, sl[f"f{i}.p"]] = _filter(b, den, dz_dx @ dxdp)
                jac[:, sl[f"f{i}.y"]] = _filter(b, den, dz_dy)
            else:
                v = x
            w = _filter(b, den, v)
            s += w
            jac[:, sl[f"h1{i}.b"]] = _lagged(blocks.cascade(den, v), len(b))
            if spec.np1:
                jac[:, sl[f"h1{i}.a"]] = _den_sensitivity(den, dden, w, spec.np1)
        upstream = slice(0, sl["g.p"].start if self.g else (sl["h2.a"].start if self.h2 else sl["offset"].start))
        z = s
        if self.g:
            gx, gy, dxdp = self.g
            if self.g_sigma > 0:
                z, slope, dz_dx, dz_dy, dz_ds = blocks.pwl_expected(gx, gy, s, self.g_sigma, derivatives=True)
                jac[:, sl["g.s"]] = (dz_ds * self.g_sigma)[:, None]  # d/d log(sigma)
            else:
                z, slope, dz_dx, dz_dy = blocks.pwl_eval(gx, gy, s, derivatives=True)
            jac[:, upstream] *= slope[:, None]
            jac[:, sl["g.p"]] = dz_dx @ dxdp
            jac[:, sl["g.y"]] = dz_dy
        if self.h2:
            b, den, dden = self.h2
            through = slice(0, sl["h2.a"].start)
            jac[:, through] = _filter(b, den, jac[:, through])
            y = _filter(b, den, z)
            jac[:, sl["h2.b"]] = _lagged(blocks.cascade(den, z), len(b))
            if spec.np2:
                jac[:, sl["h2.a"]] = _den_sensitivity(den, dden, y, spec.np2)
            z = y
        jac[:, sl["offset"]] = 1.0
        return z + self.offset, jac
