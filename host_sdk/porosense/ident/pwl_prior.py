"""A prior on the bends of the piecewise-linear maps, weighted by the data's own error level.

A map's slope between breakpoints k and k + 1 is s_k = (y_(k+1) - y_k) / (x_(k+1) - x_k). Where
breakpoints crowd together, a small change of the values gives a large change of slope: the
map can grow a spike that a few samples pay for (the slow creep of a held step, turned into a
steep segment), which fits the estimation data by a hair and leaves the map ill-conditioned:
steep segments that the fixed-point estimator cannot follow. The prior is on the slope changes
at the inner breakpoints, relative to the map's typical slope S, the RMS slope between its
inner breakpoints (S^2 = sum h_k s_k^2 / sum h_k over the segments between x_1 and x_(n-2); the
end segments' outer ends are free beyond the data)::

    e_j = (s_(j+1) - s_j) / S,     e_j ~ N(0, 1)

so a map may bend by about its own slope at each breakpoint (a knee from slope 1 to 0 costs
e^2 ~ 1) while a bump of height a over a width w costs about 2 L / w for a map of inner span L
(hundreds for the spike above). The ratio is dimensionless and does not change when the map's
input or output is rescaled, so it does not push a model along the scales a WH model leaves
free between H1, g and H2.

Its weight against the simulation error follows from the likelihood: with residuals of
variance sigma^2 correlated over an integrated autocorrelation time tau (samples), N residuals
carry the information of N / tau independent ones, and -2 log posterior, times sigma^2 tau, is

    SSE + sigma^2 tau sum_j e_j^2.

sigma^2 and tau are measured on the residuals of the refinement's start (one weight per
refinement, so the objective is fixed while it runs): the mean squared residual and the
integrated autocorrelation time of each recording's residuals with Sokal's self-consistent
window (the lag sum stops at the first M >= SOKAL_C * tau(M)). Nothing in it is fitted to a
data set.
"""

from __future__ import annotations

import numpy as np

from porosense.ident import blocks
from porosense.ident.chain import ChainSpec

# Sokal's window constant: the lag sum of the autocorrelation stops at M >= SOKAL_C tau(M), which
# keeps its bias below exp(-SOKAL_C) for an exponential decay while the variance stays O(M / N).
SOKAL_C = 5.0
# The smallest typical slope S, relative to the map's steepest segment: a map flat between its
# inner breakpoints to this level has no slope to be relative to (no prior on it).
_FLAT = 1e-9


def autocorrelation_time(r) -> float:
    """Integrated autocorrelation time of the sequence ``r``, samples (1 for white noise).

    tau = 1 + 2 sum_(k=1..M) rho_k with Sokal's window M (the first M >= SOKAL_C tau(M)); rho_k the
    sample autocorrelation (from its FFT). At least 1 and at most the length of ``r``.
    """
    r = np.asarray(r, dtype=float)
    n = len(r)
    if n < 4:
        return 1.0
    r = r - np.mean(r)
    var = float(r @ r)
    if not var > 0:
        return 1.0
    size = 1 << int(2 * n - 1).bit_length()
    spec = np.fft.rfft(r, size)
    acf = np.fft.irfft(spec * np.conj(spec), size)[:n] / var
    taus = 1.0 + 2.0 * np.cumsum(acf[1:])
    window = np.flatnonzero(np.arange(1, n) >= SOKAL_C * taus)
    tau = float(taus[window[0]]) if len(window) else float(taus[-1])
    return float(min(max(tau, 1.0), n))


def prior_weight(residuals) -> float:
    """The weight of the slope-change prior against the sum of squared residuals.

    Parameters
    ----------
    residuals : list of ndarray
        The simulation error of each recording at the refinement's start (scored samples only),
        normalised output units.

    Returns
    -------
    float
        sigma^2 tau: the mean squared residual times the samples' integrated autocorrelation time
        (their count over the effective count of independent ones), normalised output units
        squared.
    """
    rs = [np.asarray(r, dtype=float) for r in residuals if len(r)]
    n = sum(len(r) for r in rs)
    if n == 0:
        return 0.0
    sse = float(sum(r @ r for r in rs))
    n_eff = sum(len(r) / autocorrelation_time(r) for r in rs)
    return sse / n_eff


def map_names(spec: ChainSpec) -> list[str]:
    """Prefixes (``f0``, ``g``, ...) of the piecewise-linear maps of ``spec`` with inner breakpoints."""
    names = [f"f{i}" for i in range(spec.n_inputs)] if spec.f_bp >= 3 else []
    return names + (["g"] if spec.g_bp >= 3 else [])


def _p_gradient(d_dx, d) -> np.ndarray:
    """Derivatives with respect to the position parameters p from those with respect to the
    breakpoints x (last axis), ``d`` the factors of :func:`blocks.pwl_positions`:
    d/dp_j = d_j sum_(k >= j) d/dx_k."""
    return np.cumsum(d_dx[..., ::-1], axis=-1)[..., ::-1] * d


def _inner(n: int) -> slice:
    """The segments S is measured over: the inner ones (the end segments' outer ends are free
    beyond the data); with 3 breakpoints, both."""
    return slice(1, n - 2) if n >= 4 else slice(0, n - 1)


def _typical(x, y):
    """(h, s, inner, span L, energy E, S) of the map through (x, y): S^2 = E / L with E = sum h_k s_k^2
    and L = sum h_k over the inner segments; S = 0 for a map flat there (to _FLAT)."""
    h = np.diff(x)
    s = np.diff(y) / h
    inner = _inner(len(x))
    span = float(x[inner.stop] - x[inner.start])
    energy = float(np.sum(h[inner] * s[inner] ** 2))
    scale = float(np.sqrt(energy / span))
    if not scale > _FLAT * max(float(np.max(np.abs(s))), 1e-300):
        scale = 0.0
    return h, s, inner, span, energy, scale


def bends(x, y) -> np.ndarray:
    """e_j = (s_(j+1) - s_j) / S of the map through (x, y), shape (n - 2,), dimensionless (see
    :func:`bend_rows`; 0 for a map flat between its inner breakpoints)."""
    _, s, _, _, _, scale = _typical(x, y)
    return np.diff(s) / scale if scale > 0 else np.zeros(len(x) - 2)


def bend_rows(x, d, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The relative slope changes e_j of the map through (x, y) and their derivatives.

    Parameters
    ----------
    x : ndarray (n,), n >= 3
        Breakpoints, strictly increasing (normalised input units).
    d : ndarray (n,)
        The position factors of the breakpoints' unconstrained parameters
        (:func:`blocks.pwl_positions`).
    y : ndarray (n,)
        Values at the breakpoints.

    Returns
    -------
    (e, de/dp, de/dy)
        e = (s_(j+1) - s_j) / S of shape (n - 2,), dimensionless, S the map's RMS slope between
        its inner breakpoints; derivatives of shape (n - 2, n).
    """
    n = len(x)
    h, s, inner, span, energy, scale = _typical(x, y)
    if scale == 0.0:
        zero = np.zeros((n - 2, n))
        return np.zeros(n - 2), zero, zero.copy()
    lo, hi = inner.start, inner.stop  # segments lo..hi-1: breakpoints lo..hi
    si = s[inner]
    c = np.diff(s)
    # dE/dy: -2 s_k at y_k, +2 s_k at y_(k+1); dE/dx: +s_k^2 at x_k, -s_k^2 at x_(k+1); dL/dx: -1 at
    # x_lo, +1 at x_hi.
    d_energy_dy, d_energy_dx = np.zeros(n), np.zeros(n)
    d_energy_dy[lo:hi] -= 2.0 * si
    d_energy_dy[lo + 1 : hi + 1] += 2.0 * si
    d_energy_dx[lo:hi] += si**2
    d_energy_dx[lo + 1 : hi + 1] -= si**2
    d_span_dx = np.zeros(n)
    d_span_dx[lo], d_span_dx[hi] = -1.0, 1.0
    dscale_dy = d_energy_dy / (2.0 * scale * span)
    dscale_dx = (d_energy_dx / span - energy * d_span_dx / span**2) / (2.0 * scale)
    # c_j = s_(j+1) - s_j with ds_k/dy_k = -1/h_k, ds_k/dy_(k+1) = 1/h_k, ds_k/dx_k = s_k/h_k,
    # ds_k/dx_(k+1) = -s_k/h_k: three bands each.
    e = c / scale
    j = np.arange(n - 2)
    inv, sh = 1.0 / h, s / h
    de_dy, de_dx = np.zeros((n - 2, n)), np.zeros((n - 2, n))
    de_dy[j, j], de_dy[j, j + 1], de_dy[j, j + 2] = inv[:-1], -(inv[:-1] + inv[1:]), inv[1:]
    de_dx[j, j], de_dx[j, j + 1], de_dx[j, j + 2] = -sh[:-1], sh[:-1] + sh[1:], -sh[1:]
    de_dy /= scale
    de_dx /= scale
    de_dy -= np.outer(e / scale, dscale_dy)
    de_dx -= np.outer(e / scale, dscale_dx)
    return e, _p_gradient(de_dx, d), de_dy


class BendPrior:
    """The prior's extra residuals sqrt(weight) e_j over every map of a structure (an
    ``ExtraResiduals`` of :mod:`porosense.ident.refine`), its weight set at a refinement's start.

    Parameters
    ----------
    spec : ChainSpec
        The structure (maps of at least 3 breakpoints carry the prior).
    residuals : list of ndarray
        The simulation error of each recording at the start (scored samples), normalised units:
        the weight is :func:`prior_weight` of them.
    """

    def __init__(self, spec: ChainSpec, residuals):
        self.spec = spec
        self.names = map_names(spec)
        self.sl = spec.slices()
        self.weight = prior_weight(residuals)

    def residual(self, theta) -> np.ndarray:
        """sqrt(weight) e_j of every map at ``theta``, shape (m,), normalised output units."""
        theta = np.asarray(theta, dtype=float)
        w = np.sqrt(self.weight)
        out = []
        for name in self.names:
            x, _ = blocks.pwl_positions(theta[self.sl[f"{name}.p"]])
            out.append(w * bends(x, theta[self.sl[f"{name}.y"]]))
        return np.concatenate(out)

    def jacobian(self, theta) -> np.ndarray:
        """Their derivatives, shape (m, n_params)."""
        theta = np.asarray(theta, dtype=float)
        w = np.sqrt(self.weight)
        jac = []
        for name in self.names:
            x, d = blocks.pwl_positions(theta[self.sl[f"{name}.p"]])
            _, de_dp, de_dy = bend_rows(x, d, theta[self.sl[f"{name}.y"]])
            j = np.zeros((len(de_dp), self.spec.n_params))
            j[:, self.sl[f"{name}.p"]] = w * de_dp
            j[:, self.sl[f"{name}.y"]] = w * de_dy
            jac.append(j)
        return np.vstack(jac)
