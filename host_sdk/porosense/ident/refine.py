"""Simulation-error refinement shared by every structure: the fit record, the optimiser options,
the prior and penalties on piecewise-linear maps and Levenberg-Marquardt over all recordings.

All functions work on normalised data: ``us`` a list of (N_r, n_inputs) arrays, ``ys`` a list
of (N_r,) arrays, one pair per recording (each simulated from rest). They return a
:class:`Fit` holding the :class:`ChainSpec`, the parameters and the sum of squared errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from scipy.optimize import least_squares

from porosense.dsp.blas import single_threaded
from porosense.dsp.heap import reuses_freed_memory
from porosense.ident.chain import Chain, ChainSpec
from porosense.ident.lm import levenberg_marquardt, normal_equations_rows
from porosense.ident.pwl_prior import BendPrior, map_names


def lstsq(phi, rhs):
    """Least squares for tall ``phi`` through its (small) normal equations, ridge-guarded."""
    gram = phi.T @ phi
    ridge = 1e-10 * np.trace(gram) / max(len(gram), 1)
    try:
        return np.linalg.solve(gram + ridge * np.eye(len(gram)), phi.T @ rhs)
    except np.linalg.LinAlgError:
        return np.full(phi.shape[1], np.nan)


class ExtraResiduals(Protocol):
    """Extra residuals a refinement minimises beside the simulation error (a penalty or a
    soft constraint on the parameters)."""

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """The extra residuals at ``theta``, shape (m,)."""
        ...

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """Their derivatives d residual / d theta, shape (m, n_params)."""
        ...


@dataclass
class Fit:
    spec: ChainSpec
    theta: np.ndarray
    sse: float
    nfev: int = 0
    build: str = ""
    notes: dict = field(default_factory=dict)  # how a part of the fit was decided (process noise)
    converged: bool = False  # the optimiser stopped on a tolerance, not on its evaluation budget


@dataclass(frozen=True)
class Options:
    """Optimiser settings: evaluations per refinement, tolerance, samples skipped per record."""

    max_nfev: int = 200
    tol: float = 1e-7
    skip: int = 0
    starts: int = 2
    smoothness: float = 0.0
    monotone: bool = False
    frozen: tuple = ()  # indices of parameters held at their starting values
    bend_prior: bool = True  # the prior on the maps' slope changes (pwl_prior)
    constraint: ExtraResiduals | None = None  # extra residuals and their rows, or None


def sse(spec, theta, us, ys, skip=0) -> float:
    chain = Chain(spec, theta)
    return float(sum(np.sum((chain.simulate(u)[skip:] - y[skip:]) ** 2) for u, y in zip(us, ys)))


def _penalty_rows(spec: ChainSpec, theta, n_res: int, opts: Options):
    """Extra residuals and their Jacobian rows regularising the piecewise-linear values.

    Smoothness: sqrt(smoothness * n_res) times the second differences of every map's values
    (normalised units, so the weight is dimensionless: the penalty is smoothness x the mean
    squared error of a model whose maps bend by one output standard deviation per breakpoint).
    Monotone: a stiff penalty (weight n_res) on every step against the direction of the map's
    first-to-last change, so the refined maps come out monotone up to rounding.
    """
    rows, jac = [], []
    sl = spec.slices()
    names = [n for n in sl if n.endswith(".y")]
    for name in names:
        idx = np.arange(sl[name].start, sl[name].stop)
        v = theta[idx]
        if opts.smoothness > 0 and len(v) >= 3:
            w = np.sqrt(opts.smoothness * n_res)
            d2 = np.zeros((len(v) - 2, spec.n_params))
            for k in range(len(v) - 2):
                d2[k, idx[k : k + 3]] = w * np.array([1.0, -2.0, 1.0])
            rows.append(d2 @ theta)
            jac.append(d2)
        if opts.monotone and len(v) >= 2:
            sign = 1.0 if v[-1] >= v[0] else -1.0
            w = np.sqrt(float(n_res))
            step = np.diff(v) * sign
            active = step < 0
            m = np.zeros((len(v) - 1, spec.n_params))
            for k in np.flatnonzero(active).tolist():
                m[k, idx[k]], m[k, idx[k + 1]] = -w * sign, w * sign
            rows.append(np.where(active, w * step, 0.0))
            jac.append(m)
    if not rows:
        return None, None
    return np.concatenate(rows), np.vstack(jac)


@reuses_freed_memory
@single_threaded
def refine(spec: ChainSpec, theta0, us, ys, opts: Options) -> Fit:
    """Minimise the simulation error over all recordings (LM with the exact J, :mod:`lm`),
    plus the prior on the maps' slope changes (:mod:`pwl_prior`, weighted by the start's own
    residuals; ``opts.bend_prior``), the optional smoothness / monotone penalties of
    :func:`_penalty_rows` and ``opts.constraint``. The returned ``sse`` is the simulation error
    alone (normalised units squared)."""
    skip = opts.skip
    n_sim = sum(len(y) - skip for y in ys)
    regular = (opts.smoothness > 0 or opts.monotone) and (spec.f_bp or spec.g_bp)
    theta0 = np.asarray(theta0, dtype=float)
    bend = None
    if opts.bend_prior and map_names(spec):
        start = Chain(spec, theta0)
        bend = BendPrior(spec, [start.simulate(u)[skip:] - y[skip:] for u, y in zip(us, ys)])
        if not bend.weight > 0:  # a start that fits exactly: nothing to weigh the prior by
            bend = None

    def extra_residuals(theta):
        """The residuals of the penalties, the prior and the constraint (empty without them)."""
        parts = []
        if regular:
            parts.append(_penalty_rows(spec, theta, n_sim, opts)[0])
        if bend is not None:
            parts.append(bend.residual(theta))
        if opts.constraint is not None:
            parts.append(opts.constraint.residual(theta))
        parts = [q for q in parts if q is not None]
        return np.concatenate(parts) if parts else None

    def extra_rows(theta):
        """Their Jacobian rows (m, n_params), or None."""
        parts = []
        if regular:
            parts.append(_penalty_rows(spec, theta, n_sim, opts)[1])
        if bend is not None:
            parts.append(bend.jacobian(theta))
        if opts.constraint is not None:
            parts.append(opts.constraint.jacobian(theta))
        parts = [q for q in parts if q is not None]
        return np.vstack(parts) if parts else None

    def residuals(theta):
        chain = Chain(spec, theta)
        r = np.concatenate([chain.simulate(u)[skip:] - y[skip:] for u, y in zip(us, ys)])
        extra = extra_residuals(theta)
        if extra is not None:
            r = np.concatenate([r, extra])
        return np.where(np.isfinite(r), r, 1e6)

    def jacobian(theta):
        chain = Chain(spec, theta)
        j = np.vstack([chain.jacobian(u)[1][skip:] for u in us])
        extra = extra_rows(theta)
        if extra is not None:
            j = np.vstack([j, extra])
        if opts.frozen:  # a zero column: no step ever moves it
            j[:, list(opts.frozen)] = 0.0
        return np.where(np.isfinite(j), j, 0.0)

    def normal(theta, r):
        # J^T J and J^T r recording by recording: the whole Jacobian is never held at once.
        chain = Chain(spec, theta)
        a, g = np.zeros((spec.n_params, spec.n_params)), np.zeros(spec.n_params)
        pos = 0
        for u in us:
            jt = chain.jacobian_rows(u)[1][:, skip:]
            rr = r[pos : pos + jt.shape[1]]
            da, dg = normal_equations_rows(jt, rr)
            # A non-finite sensitivity shows in the products (checked there: p x p, not p x N).
            if not (np.isfinite(da).all() and np.isfinite(dg).all()):
                da, dg = normal_equations_rows(np.nan_to_num(jt, nan=0.0, posinf=0.0, neginf=0.0), rr)
            a += da
            g += dg
            pos += jt.shape[1]
        extra = extra_rows(theta)
        if extra is not None:
            j = np.nan_to_num(extra, nan=0.0, posinf=0.0, neginf=0.0)
            a += j.T @ j
            g += j.T @ r[pos:]
        if opts.frozen:  # as a zero column: no step ever moves it
            frozen = list(opts.frozen)
            a[frozen, :] = 0.0
            a[:, frozen] = 0.0
            g[frozen] = 0.0
        return a, g

    start_sse = float(np.sum(residuals(theta0) ** 2))
    n_res = sum(len(y) - skip for y in ys)
    method = "lm" if n_res >= spec.n_params else "trf"
    try:
        if method == "lm":  # tall problem: LM on the normal equations (lm.py says why)
            res = levenberg_marquardt(
                residuals,
                None,
                theta0,
                normal=normal,
                max_nfev=opts.max_nfev,
                ftol=opts.tol,
                xtol=opts.tol,
                gtol=opts.tol,
            )
            theta, cost, nfev, converged = res.x, res.cost, res.nfev, res.status != "max_nfev"
        else:
            res = least_squares(
                residuals,
                theta0,
                jac=jacobian,
                method=method,
                max_nfev=opts.max_nfev,
                ftol=opts.tol,
                xtol=opts.tol,
                gtol=opts.tol,
                x_scale=1.0,
            )
            theta, cost, nfev, converged = res.x, 2.0 * res.cost, res.nfev, res.status > 0
    except (np.linalg.LinAlgError, ValueError):
        theta, cost, nfev, converged = theta0, start_sse, 0, True
    if not cost <= start_sse:
        theta, cost = theta0, start_sse
    if regular or bend is not None or opts.constraint is not None:  # report the simulation error alone
        cost = sse(spec, theta, us, ys, skip)
    return Fit(spec, theta, float(cost), int(nfev), converged=converged)


def multistart(spec: ChainSpec, starts, us, ys, opts: Options) -> Fit:
    """Refine every start briefly, then continue the best one with the remaining budget."""
    if len(starts) == 1:
        return refine(spec, starts[0], us, ys, opts)
    screen = max(opts.max_nfev // 10, 8)
    short = replace(opts, max_nfev=screen, tol=max(opts.tol, 1e-5))
    best = best_fit([refine(spec, t, us, ys, short) for t in starts])
    rest = replace(opts, max_nfev=max(opts.max_nfev - screen, 1))
    final = refine(spec, best.theta, us, ys, rest)
    final.nfev += screen * len(starts)
    return final


def best_fit(fits: list[Fit]) -> Fit:
    return min(fits, key=lambda f: f.sse if np.isfinite(f.sse) else np.inf)
