"""Parametrised blocks with their derivatives: stable denominators and piecewise-linear maps.

A denominator of n poles is a cascade of n // 2 second-order sections (plus one first-order
section when n is odd). Each section 1 + a1 z^-1 + a2 z^-2 is parametrised by two reflection
coefficients k = K tanh(theta) with |k| < K < 1: a2 = k2, a1 = k1 (1 + k2). That maps onto
the whole stability triangle, so every parameter vector gives a stable filter, and the
sections are filtered one after the other (numerically robust for clustered poles near
z = 1, and exactly the SOS form the firmware runs).

Piecewise-linear maps have free breakpoints: x_0 = p_0, x_k = x_{k-1} + exp(p_k), so the
breakpoints stay strictly increasing for any parameter vector. One function evaluates them with
their derivatives (:func:`pwl_rows`), for the Jacobian and for every basis built from them.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np
from scipy.signal import lfilter

from porosense.dsp import fold_delay

# |k| < _K_MAX keeps every pole a margin inside the unit circle in floating point too.
_K_MAX = 1.0 - 1e-10


_K_CLIP = 1.0 - 1e-12


def n_sections(n_poles: int) -> int:
    return (n_poles + 1) // 2


def sections(theta) -> tuple[np.ndarray, np.ndarray]:
    """(den, dden) for ``theta`` of n poles: den (n_sec, 3) rows [1, a1, a2]; dden (n_sec, 2, 2)
    with dden[s, i, j] = d a_(i+1) / d theta_j of section s (theta_j its own parameters)."""
    theta = np.asarray(theta, dtype=float)
    n = len(theta)
    m = n_sections(n)
    den = np.zeros((m, 3))
    den[:, 0] = 1.0
    dden = np.zeros((m, 2, 2))
    for s in range(m):
        t = theta[2 * s : 2 * s + 2]
        k = _K_MAX * np.tanh(t)
        dk = _K_MAX * (1.0 - np.tanh(t) ** 2)
        if len(t) == 2:
            den[s, 1] = k[0] * (1.0 + k[1])
            den[s, 2] = k[1]
            dden[s, 0, 0] = dk[0] * (1.0 + k[1])
            dden[s, 0, 1] = k[0] * dk[1]
            dden[s, 1, 1] = dk[1]
        else:
            den[s, 1] = k[0]
            dden[s, 0, 0] = dk[0]
    return den, dden


def _pair_roots(roots, n_poles: int):
    """Group roots into conjugate pairs / real pairs, a lone real root last (odd count)."""
    roots = np.asarray(roots, dtype=complex)
    cplx = [r for r in roots if r.imag > 1e-12]
    real = sorted([r.real for r in roots if abs(r.imag) <= 1e-12], key=abs, reverse=True)
    groups: list[tuple] = [(r, np.conj(r)) for r in cplx]
    lone = None
    if n_poles % 2 == 1 and real:
        lone = real.pop()
    while len(real) >= 2:
        groups.append((real.pop(0), real.pop(0)))
    if real:  # an odd real left over (odd count with conjugates unpaired): pair with origin
        groups.append((real.pop(), 0.0))
    if lone is not None:
        groups.append((lone,))
    return groups


def theta_from_poly(a, n_poles: int) -> np.ndarray:
    """Parameters whose cascade has the (stabilised) roots of the monic denominator ``a``."""
    a = np.asarray(a, dtype=float)
    a = a / a[0]
    roots = np.roots(a) if len(a) > 1 else np.array([])
    roots = np.concatenate([roots, np.zeros(max(n_poles - len(roots), 0))])[:n_poles]
    big = np.abs(roots) > 0.99995
    roots[big] = 0.99995 * roots[big] / np.abs(roots[big])
    theta = np.zeros(n_poles)
    for s, grp in enumerate(_pair_roots(roots, n_poles)):
        poly = np.real(np.poly(grp))
        if len(grp) == 2:
            k2 = poly[2]
            k1 = poly[1] / (1.0 + k2)
            theta[2 * s : 2 * s + 2] = np.arctanh(np.clip(np.array([k1, k2]) / _K_MAX, -_K_CLIP, _K_CLIP))
        else:
            theta[2 * s] = np.arctanh(np.clip(poly[1] / _K_MAX, -_K_CLIP, _K_CLIP))
    return theta


def den_poly(den) -> np.ndarray:
    """The product polynomial of the section rows."""
    a = np.ones(1)
    for row in den:
        a = np.convolve(a, row)
    return a


def cascade(den, x, axis=0):
    """Filter ``x`` through 1 / prod(sections) from rest."""
    for row in den:
        x = lfilter([1.0], row, x, axis=axis)
    return x


def sos_rows(b, den) -> np.ndarray:
    """SOS rows [b0 b1 b2 1 a1 a2] of B(z^-1) / prod(sections) without touching the poles.

    The numerator is factored into quadratics (its roots); leading zeros of ``b`` (pure
    delays) go into free numerator slots or extra delay sections.
    """
    b = np.atleast_1d(np.asarray(b, dtype=float))
    nz = np.flatnonzero(b)
    if len(nz) == 0:
        rows = np.zeros((max(len(den), 1), 6))
        rows[:, 3] = 1.0
        rows[: len(den), 3:] = den
        return rows
    delay = int(nz[0])
    bt = np.trim_zeros(b[delay:], "b")
    gain = bt[0]
    zeros = np.roots(bt) if len(bt) > 1 else np.array([])
    quads = [np.real(np.poly(g)) for g in _pair_roots(zeros, len(zeros))]
    quads = [np.pad(q, (0, 3 - len(q))) for q in quads]
    n = max(len(den), len(quads), 1)
    rows = np.zeros((n, 6))
    rows[:, 0] = 1.0
    rows[:, 3] = 1.0
    for i, q in enumerate(quads):
        rows[i, :3] = q
    rows[: len(den), 3:] = den
    rows[0, :3] *= gain
    return fold_delay(rows, delay)


def stabilise(a) -> np.ndarray:
    """Reflect roots outside the unit circle inside (keeps the magnitude response shape)."""
    a = np.asarray(a, dtype=float)
    if len(a) <= 1:
        return a
    r = np.roots(a)
    big = np.abs(r) >= 0.999
    if not np.any(big):
        return a
    r[big] = r[big] / np.abs(r[big]) ** 2  # reflect into the unit disc
    near = np.abs(r) >= 0.999
    r[near] = 0.999 * r[near] / np.abs(r[near])
    return np.real(np.poly(r)) * a[0]


# ------------------------------------------------------------------ piecewise linear maps


def pwl_positions(p) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoint positions x from unconstrained ``p`` and their derivative factors d (n,):
    dx_k/dp_j = d_j for j <= k and 0 beyond (d_0 = 1; :func:`positions_jacobian`)."""
    p = np.asarray(p, dtype=float)
    # The floor keeps breakpoints distinct (normalised units, so 2e-9 is negligible).
    raw = p[1:]
    steps = np.exp(np.clip(raw, -20.0, 50.0))
    x = p[0] + np.concatenate([[0.0], np.cumsum(steps)])
    d = np.empty(len(p))
    d[0] = 1.0
    d[1:] = np.where((raw > -20.0) & (raw < 50.0), steps, 0.0)  # flat where clipped
    return x, d


def positions_jacobian(d) -> np.ndarray:
    """dx/dp (n, n), lower triangular, from the factors ``d`` of :func:`pwl_positions`."""
    return np.tril(np.ones((len(d), len(d)))) * d


def positions_to_p(x) -> np.ndarray:
    """Unconstrained parameters of strictly increasing breakpoints ``x``."""
    x = np.asarray(x, dtype=float)
    return np.concatenate([[x[0]], np.log(np.diff(x))])


def pwl_eval(x, y, u, derivatives: bool = False):
    """Evaluate the map through (x, y) at u, linear beyond the ends.

    With ``derivatives``, also returns the slope dz/du (N,), dz/dx (N, n) and dz/dy (N, n)
    (the rows of :func:`pwl_rows`, transposed into C order: least squares on them then runs the
    same products as ever).
    """
    if not derivatives:
        u = np.asarray(u, dtype=float)
        k = np.clip(np.searchsorted(x, u, side="right") - 1, 0, len(x) - 2)
        xk, yk = x[k], y[k]
        return yk + (y[k + 1] - yk) * ((u - xk) / (x[k + 1] - xk))
    z, slope, dz_dx, dz_dy = pwl_rows(x, y, u)
    return z, slope, np.ascontiguousarray(dz_dx.T), np.ascontiguousarray(dz_dy.T)


def pwl_rows(x, y, u, d=None, out=None):
    """The map through (x, y) at u (linear beyond the ends) with its derivatives as rows.

    Parameters
    ----------
    x, y : ndarray (n,)
        Breakpoints (strictly increasing) and values.
    u : ndarray (N,)
        Where the map is evaluated, in the units of x.
    d : ndarray (n,) or None
        The factors of :func:`pwl_positions`: the rows are then with respect to the position
        parameters p instead of x.
    out : (ndarray, ndarray) or None
        Two (n, N) float arrays the derivative rows are written into (None: new arrays).

    Returns
    -------
    (z, slope, dz/dx or dz/dp, dz/dy)
        z and the slope dz/du of shape (N,); the derivatives as rows, shape (n, N).
    """
    u = np.asarray(u, dtype=float)
    n, m = len(x), len(u)
    k = np.clip(np.searchsorted(x, u, side="right") - 1, 0, n - 2)
    xk, yk = x[k], y[k]
    h = x[k + 1] - xk
    t = (u - xk) / h
    dy = y[k + 1] - yk
    z = yk + dy * t
    slope = dy / h
    cols = np.arange(m)

    def zeros(i):  # row block i of ``out`` cleared, or a new one
        if out is None:
            return np.zeros((n, m))
        out[i].fill(0.0)
        return out[i]

    dz_dy = zeros(1)
    dz_dy[k, cols] = 1.0 - t
    dz_dy[k + 1, cols] = t
    dz_dx = zeros(0) if d is None else np.zeros((n, m))
    dz_dx[k, cols] = slope * (t - 1.0)
    dz_dx[k + 1, cols] = -slope * t
    if d is None:
        return z, slope, dz_dx, dz_dy
    dz_dp = np.matmul(positions_jacobian(d).T, dz_dx, out=None if out is None else out[0])
    return z, slope, dz_dp, dz_dy


def initial_breakpoints(values, n: int) -> np.ndarray:
    """``n`` strictly increasing breakpoints spread over the quantiles of ``values``."""
    v = np.asarray(values, dtype=float)
    lo, hi = np.quantile(v, [0.0, 1.0])
    if not hi > lo:
        lo, hi = lo - 1.0, hi + 1.0
    q = np.quantile(v, np.linspace(0.0, 1.0, n))
    # Blend quantiles with an even grid so that no two breakpoints coincide.
    x = 0.7 * q + 0.3 * np.linspace(lo, hi, n)
    min_gap = 1e-3 * (hi - lo)
    for i in range(1, n):
        x[i] = max(x[i], x[i - 1] + min_gap)
    return x


def pwl_expected(x, y, u, sigma: float, derivatives: bool = False):
    """E[g(u + v)] for the map g through (x, y) (linear beyond the ends) and v ~ N(0, sigma^2).

    g = y_0 + s_0 (u - x_0) + sum_k (s_k - s_(k-1)) max(0, u - x_k) over the inner breakpoints,
    and each hinge's expectation is closed form: E max(0, d + v) = d Phi(d/sigma) + sigma phi(d/sigma).
    So a map learnt through this expectation is the noise-free g of a system whose noise enters
    before g. ``sigma`` > 0 in the units of u. With ``derivatives``, also returns dz/du (N,),
    dz/dx (N, n), dz/dy (N, n) and dz/dsigma (N,).
    """
    u = np.asarray(u, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    n = len(x)
    dx = np.diff(x)
    s = np.diff(y) / dx  # slopes of the n - 1 segments
    c = np.diff(s)  # slope changes at the inner breakpoints x_1..x_(n-2)
    cdf, pdf, hinge = _hinges(x[1:-1], u, float(sigma))
    z = y[0] + s[0] * (u - x[0]) + hinge @ c
    if not derivatives:
        return z
    slope = s[0] + cdf @ c
    dz_dsigma = pdf @ c
    # dz/ds_j = G_j - G_(j+1) with G_0 = u - x_0, G_j = hinge_j (inner), G_(n-1) = 0.
    big_g = np.column_stack([u - x[0], hinge, np.zeros(len(u))])
    dz_ds = big_g[:, :-1] - big_g[:, 1:]  # (N, n - 1)
    # s_j = (y_(j+1) - y_j) / dx_j.
    dz_dy = np.zeros((len(u), n))
    dz_dy[:, 0] = 1.0
    dz_dy[:, 1:] += dz_ds / dx
    dz_dy[:, :-1] -= dz_ds / dx
    dz_dx = np.zeros((len(u), n))
    dz_dx[:, 0] -= s[0]
    dz_dx[:, 1:-1] -= cdf * c
    ds_w = dz_ds * (s / dx)  # ds_j/dx_j = s_j/dx_j, ds_j/dx_(j+1) = -s_j/dx_j
    dz_dx[:, :-1] += ds_w
    dz_dx[:, 1:] -= ds_w
    return z, slope, dz_dx, dz_dy, dz_dsigma


#: Hinge expectations of :func:`pwl_expected` kept for their inputs (a fit's Jacobian follows the
#: simulation at the same parameters and signal: the normal CDF, most of its cost, is computed once).
_HINGES: OrderedDict = OrderedDict()
_HINGES_KEEP = 2  # a fit makes one other call between the simulation and the Jacobian at one point
_HINGES_LOCK = threading.Lock()


def _hinges(inner, u, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normal CDF and density of ``(u - inner) / sigma`` and the hinges' expectations
    ``E max(0, u - inner + v)`` (each (N, len(inner)), read-only), for v ~ N(0, sigma^2)."""
    from scipy.special import ndtr

    key = (inner.tobytes(), u.tobytes(), sigma)
    with _HINGES_LOCK:
        hit = _HINGES.get(key)
        if hit is not None:
            _HINGES.move_to_end(key)
            return hit
    d = u[:, None] - inner[None, :]  # (N, n - 2)
    t = d / sigma
    cdf = ndtr(t)
    pdf = np.exp(-0.5 * t * t) / np.sqrt(2.0 * np.pi)
    hinge = d * cdf + sigma * pdf
    for a in (cdf, pdf, hinge):
        a.flags.writeable = False
    with _HINGES_LOCK:
        _HINGES[key] = (cdf, pdf, hinge)
        while len(_HINGES) > _HINGES_KEEP:
            _HINGES.popitem(last=False)
    return cdf, pdf, hinge
