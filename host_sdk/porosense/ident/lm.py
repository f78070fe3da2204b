"""Levenberg-Marquardt on the normal equations, for tall simulation-error problems.

MINPACK's LM (scipy's ``least_squares(method="lm")``) factors the whole N x p Jacobian by a
column-pivoted QR at every iteration; with N in the thousands to hundreds of thousands and
p ~ 40 that factorisation costs more than simulating the model and its sensitivities. Here
every Jacobian is reduced once to J^T J and J^T r (p x p) and each trial step solves a p x p
Cholesky system, so an iteration costs about one Jacobian.

Damping: Levenberg's mu I, in units of the largest diagonal entry of the first J^T J (as
MINPACK with fixed unit scaling), updated by Nielsen's rule. Convergence is judged on the
undamped Gauss-Newton step of each new Jacobian, so a step kept small by the damping is never
taken for convergence: ftol (predicted relative reduction), xtol (relative step) and gtol (the
largest cosine between r and a column of J, as MINPACK's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

# Nielsen's starting damping, relative to the largest diagonal entry of J^T J.
MU0 = 1e-3


@dataclass
class LMResult:
    x: np.ndarray
    cost: float  # sum of squared residuals at x
    nfev: int  # residual evaluations (the initial one included)
    njev: int
    status: str


# OpenBLAS runs a product on all its threads once M*N*K passes 65536 * 4; on a busy 2-core
# machine (a process pool already uses every core) the threads cost 10-20x more than they
# save. Row blocks below that size keep each product on the calling thread.
_BLOCK_MNK = 200_000


def _normal_equations(j, r):
    """(J^T J, J^T r) accumulated over row blocks of ``j`` (N, p), see _BLOCK_MNK."""
    return normal_equations_rows(np.ascontiguousarray(j.T), r)


def normal_equations_rows(jt, r):
    """(J^T J, J^T r) of the transposed Jacobian ``jt`` (p, N), accumulated over column blocks
    (see _BLOCK_MNK)."""
    p = jt.shape[0]
    cols = max(8, _BLOCK_MNK // max(p * p, 1))
    a, g = np.zeros((p, p)), np.zeros(p)
    for i in range(0, jt.shape[1], cols):
        blk = jt[:, i : i + cols]
        a += blk @ blk.T
        g += blk @ r[i : i + cols]
    return a, g


def levenberg_marquardt(
    fun,
    jac,
    x0,
    *,
    normal=None,
    max_nfev: int = 200,
    ftol: float = 1e-7,
    xtol: float = 1e-7,
    gtol: float = 1e-7,
) -> LMResult:
    """Minimise ||fun(x)||^2 from ``x0``; ``jac(x)`` returns d fun / dx (N, p), or ``normal(x, r)``
    returns (J^T J, J^T r) at x with r = fun(x) directly (then ``jac`` may be None: a caller that
    accumulates them piece by piece never holds the whole Jacobian).

    ``max_nfev`` bounds the residual evaluations (as MINPACK's maxfev). Only steps that lower
    the cost are taken, so the returned cost never exceeds the start's.
    """
    x = np.array(x0, dtype=float)
    r = np.asarray(fun(x), dtype=float)
    nfev, njev = 1, 0
    f = float(r @ r)
    if x.size == 0 or f == 0.0 or not np.isfinite(f):
        return LMResult(x, f, nfev, njev, "zero or non-finite cost, or no parameters")
    unit: float | None = None  # the damping's scale: the largest curvature at the first Jacobian
    mu, nu = MU0, 2.0
    status = "max_nfev"
    fresh = True
    eye = np.eye(x.size)
    while nfev < max(max_nfev, 1):
        if fresh:
            a, g = normal(x, r) if normal is not None else _normal_equations(jac(x), r)
            njev += 1
            d = np.diag(a)
            if unit is None:
                unit = max(float(np.max(d)), 1e-300)
            if np.max(np.abs(g) / np.sqrt(np.where(d > 0, d, np.inf) * f)) <= gtol:
                status = "gtol"
                break
            gauss_newton = np.linalg.lstsq(a, -g, rcond=None)[0]
            if float(-g @ gauss_newton) <= ftol * f:
                status = "ftol"
                break
            if np.linalg.norm(gauss_newton) <= xtol * (np.linalg.norm(x) + xtol):
                status = "xtol"
                break
            fresh = False
        assert unit is not None  # the first pass is fresh and sets it
        try:
            step = -cho_solve(cho_factor(a + (mu * unit) * eye), g)
        except (LinAlgError, ValueError):
            step = None
        if step is not None:
            predicted = float(step @ (mu * unit * step - g))
            r_new = np.asarray(fun(x + step), dtype=float)
            nfev += 1
            f_new = float(r_new @ r_new)
            rho = (f - f_new) / predicted if predicted > 0 and np.isfinite(f_new) else -1.0
        else:
            rho = -1.0
        if rho > 0:
            x, r, f = x + step, r_new, f_new
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            fresh = True
        else:
            mu, nu = mu * nu, nu * 2.0
            if mu > 1e20:
                status = "no descent"
                break
    return LMResult(x, f, nfev, njev, status)
