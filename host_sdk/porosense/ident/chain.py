"""The block chain every model is a special case of, its simulation and its exact Jacobian.

One output over n inputs (all in normalised units inside ident)::

    y = offset + H2( g( sum_i B_i/F_i ( f_i( u_i[k - delay] ) ) ) )

Blocks are switched on by :class:`ChainSpec`. The Jacobian of the simulated output with
respect to every parameter is computed with filtered sensitivity signals: for w = B/F v,
dw/db_k = q^-k v/F and dw/da_k = -q^-k w/F; upstream sensitivities pass through the
downstream blocks (times g'(s), then through H2). Denominators are cascades of stable
sections (:mod:`porosense.ident.blocks`); for a section F_s, dw/da_(s,j) = -q^-j w/F_s.
Everything simulates from rest.

Cost: one Jacobian is O(N p) in time and memory (N samples, p parameters). It is built
transposed, one row per parameter, so that every filter runs along contiguous memory, and the
cascades run as one ``sosfilt`` call over all rows at once.

Process noise (``g_noise``): a Gaussian v of standard deviation sigma = exp(theta["g.s"]) adds
to g's input, so the expected output is y = offset + H2(E_v g(s + v)) (closed form for a
piecewise-linear g, :func:`blocks.pwl_expected`). Estimation fits that expectation; the
noise-free system (g itself) is what ``simulate(u, expected=False)`` returns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import sosfilt

from porosense.ident import blocks

try:  # the compiled loop behind scipy.signal.sosfilt, without its per-call argument handling
    from scipy.signal._sosfilt import _sosfilt as _sosfilt_loop
except ImportError:  # pragma: no cover - another scipy layout: the public function does the same
    _sosfilt_loop = None


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
    """Delay by k samples from rest along the last axis."""
    if k == 0:
        return x
    out = np.zeros_like(x)
    if k < x.shape[-1]:
        out[..., k:] = x[..., :-k]
    return out


def _fir(b, x):
    """B(q) x along the last axis, from rest (a few shifted sums: b is short)."""
    b = np.asarray(b, dtype=float)
    out = b[0] * x
    n = x.shape[-1]
    for k in range(1, min(len(b), n)):
        if b[k] != 0.0:
            out[..., k:] += b[k] * x[..., : n - k]
    return out


def _fir_into(b, x, out):
    """``out`` = B(q) x along the last axis, from rest (the arithmetic of :func:`_fir`, written into
    ``out``, an array of x's shape that is not x)."""
    n = x.shape[-1]
    np.multiply(x, b[0], out=out)
    for k in range(1, min(len(b), n)):
        if b[k] != 0.0:
            out[..., k:] += b[k] * x[..., : n - k]
    return out


def _sos(den) -> np.ndarray:
    """scipy sos rows [1 0 0 1 a1 a2] of the denominator sections ``den`` (rows [1 a1 a2])."""
    sos = np.zeros((len(den), 6))
    sos[:, 0] = 1.0
    sos[:, 3:] = den
    return sos


def cascade_rows(den, x):
    """1 / prod(sections) applied along the last axis of ``x`` from rest.

    The per-call argument handling of ``sosfilt`` costs more than the filtering of a few
    thousand samples, and a Jacobian calls it hundreds of times: its compiled loop is called
    directly (on a copy, as sosfilt does)."""
    if len(den) == 0:
        return np.array(x, dtype=float)
    x = np.asarray(x, dtype=float)
    if _sosfilt_loop is None:  # pragma: no cover
        return sosfilt(_sos(den), x, axis=-1)
    out = np.array(x.reshape(-1, x.shape[-1]), dtype=float, order="C")
    _sosfilt_loop(_sos(den), out, np.zeros((out.shape[0], len(den), 2)))
    return out.reshape(x.shape)


def _cascade_in_place(den, x) -> None:
    """1 / prod(sections) applied along the last axis of the C-contiguous 2-D float array ``x``,
    from rest, in place (:func:`cascade_rows` without its copy)."""
    if len(den) == 0:
        return
    if _sosfilt_loop is None:  # pragma: no cover
        x[...] = sosfilt(_sos(den), x, axis=-1)
        return
    _sosfilt_loop(_sos(den), x, np.zeros((x.shape[0], len(den), 2)))


def block_filter(b, den, x):
    """B(q) / prod F_s(q) applied to ``x`` from rest: 1-D, or 2-D along axis 0 (N, k)."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        return cascade_rows(den, _fir(b, x))
    return np.ascontiguousarray(cascade_rows(den, _fir(b, np.ascontiguousarray(x.T)))).T


def _den_sensitivity(den, dden, w, n_poles):
    """dw/dtheta (n_poles, N) of w = B/F v with respect to the denominator parameters."""
    out = np.zeros((n_poles, len(w)))
    for s, row in enumerate(den):
        ws = cascade_rows(row[None, :], w)
        j = slice(2 * s, min(2 * s + 2, n_poles))
        k = j.stop - j.start
        d = dden[s][:, :k]  # d a_(i+1) / d theta_j
        out[j] = -(d[0][:, None] * _shift(ws, 1)[None, :] + d[1][:, None] * _shift(ws, 2)[None, :])
    return out


def _lagged(x, n: int):
    """Rows q^0 x .. q^-(n-1) x, shape (n, N)."""
    out = np.zeros((n, len(x)))
    for k in range(n):
        out[k, k:] = x[: len(x) - k]
    return out


class Chain:
    """Decoded parameters of a :class:`ChainSpec`; ``simulate`` and ``jacobian`` on inputs."""

    def __init__(self, spec: ChainSpec, theta):
        self.spec = spec
        self.theta = np.asarray(theta, dtype=float)
        sl = spec.slices()
        self.sl = sl
        t = self.theta
        # (breakpoints, values, position factors of blocks.pwl_positions) per input; None: no f.
        self.f: list[tuple[np.ndarray, np.ndarray, np.ndarray] | None] = []
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
        return [_shift(np.ascontiguousarray(u[:, i]), self.spec.delay) for i in range(self.spec.n_inputs)]

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
            z = block_filter(b, den, z)
        return z + self.offset

    def linear_sum(self, u) -> np.ndarray:
        """s = sum_i H1_i(f_i(u_i)), the signal entering g."""
        xs = self.branch_inputs(u)
        s = np.zeros(len(xs[0]))
        for i, x in enumerate(xs):
            f = self.f[i]
            if f is not None:
                x = blocks.pwl_eval(f[0], f[1], x)
            b, den, _ = self.h1[i]
            s += block_filter(b, den, x)
        return s

    # -- Jacobian -----------------------------------------------------------------

    def jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """(y, dy/dtheta) with dy/dtheta of shape (N, n_params)."""
        y, jt = self.jacobian_rows(u)
        return y, jt.T

    def jacobian_rows(self, u) -> tuple[np.ndarray, np.ndarray]:
        """(y, dy/dtheta transposed): the sensitivities as rows, shape (n_params, N)."""
        spec, sl = self.spec, self.sl
        xs = self.branch_inputs(u)
        n = len(xs[0])
        jt = np.zeros((spec.n_params, n))
        s = np.zeros(n)
        # Rows that pass through g and H2 are collected first (sensitivities of s).
        for i, x in enumerate(xs):
            b, den, dden = self.h1[i]
            # One cascade call filters every row of the branch in place: [f's rows through B; B v; v].
            f = self.f[i]
            if f is not None:
                nf = spec.f_bp
                raw = np.empty((2 * nf + 1, n))
                raw[2 * nf], _, _, _ = blocks.pwl_rows(f[0], f[1], x, f[2], out=(raw[:nf], raw[nf : 2 * nf]))
                work = np.empty((2 * nf + 2, n))
                _fir_into(b, raw, work[:-1])
                work[-1] = raw[2 * nf]
                _cascade_in_place(den, work)
                jt[sl[f"f{i}.p"]], jt[sl[f"f{i}.y"]] = work[:nf], work[nf : 2 * nf]
                w, vf = work[-2], work[-1]
            else:
                work = np.empty((2, n))
                _fir_into(b, x, work[0])
                work[1] = x
                _cascade_in_place(den, work)
                w, vf = work
            s += w
            jt[sl[f"h1{i}.b"]] = _lagged(vf, len(b))
            if spec.np1:
                jt[sl[f"h1{i}.a"]] = _den_sensitivity(den, dden, w, spec.np1)
        upstream = slice(0, sl["g.p"].start if self.g else (sl["h2.a"].start if self.h2 else sl["offset"].start))
        z = s
        if self.g:
            gx, gy, gd = self.g
            if self.g_sigma > 0:
                z, slope, dz_dx, dz_dy, dz_ds = blocks.pwl_expected(gx, gy, s, self.g_sigma, derivatives=True)
                jt[sl["g.s"]] = dz_ds * self.g_sigma  # d/d log(sigma)
                jt[sl["g.p"]] = blocks.positions_jacobian(gd).T @ dz_dx.T
                jt[sl["g.y"]] = dz_dy.T
            else:
                z, slope, _, _ = blocks.pwl_rows(gx, gy, s, gd, out=(jt[sl["g.p"]], jt[sl["g.y"]]))
            jt[upstream] *= slope[None, :]
        if self.h2:
            b, den, dden = self.h2
            # Every row before H2's own goes through H2, in place (the leading rows of jt are one
            # C-contiguous block); z and B z beside them.
            head = jt[: sl["h2.a"].start]
            if len(b) > 1 and np.any(b[1:] != 0.0):
                _fir_into(b, head.copy(), head)
            else:
                head *= b[0]
            _cascade_in_place(den, head)
            zz = np.empty((2, n))
            _fir_into(b, z, zz[0])
            zz[1] = z
            _cascade_in_place(den, zz)
            y, zf = zz
            jt[sl["h2.b"]] = _lagged(zf, len(b))
            if spec.np2:
                jt[sl["h2.a"]] = _den_sensitivity(den, dden, y, spec.np2)
            z = y
        jt[sl["offset"]] = 1.0
        return z + self.offset, jt
