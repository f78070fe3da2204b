"""Circle fit of points on an arc, stable down to zero curvature (a straight line).

An algebraic fit (Pratt: A(x^2+y^2) + Bx + Cy + D = 0 with B^2 + C^2 - 4AD = 1, whose
signed curvature is 2A and which stays finite for a line) starts a geometric least-squares
refinement in the (curvature, direction, offset) parameters used for particle tracks, whose
residual is the exact signed distance to the circle and does not blow up as the radius grows.
The curvature's standard uncertainty comes from the Jacobian and the residual scatter.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import least_squares


@dataclass
class CircleFit:
    """Signed curvature (1/unit of the points) with its standard uncertainty; rms residual."""

    curvature: float
    curvature_std: float
    rms_residual: float
    n_points: int

    @property
    def radius(self) -> float:
        return float(np.inf) if self.curvature == 0 else 1.0 / abs(self.curvature)

    def to_dict(self) -> dict:
        return asdict(self)


def _pratt(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Algebraic circle (A, B, C, D), normalised by Pratt's constraint; centred data."""
    z = x * x + y * y
    m = np.column_stack([z, x, y, np.ones_like(x)])
    s = m.T @ m / len(x)
    # Constraint matrix of B^2 + C^2 - 4AD: generalised eigenproblem S v = eta N v.
    n = np.array([[0, 0, 0, -2.0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [-2.0, 0, 0, 0]])
    eta, vecs = np.linalg.eig(np.linalg.solve(n, s))
    eta = np.real(eta)
    ok = eta >= -1e-12 * max(1.0, np.abs(eta).max())
    k = np.flatnonzero(ok)[np.argmin(eta[ok])] if ok.any() else int(np.argmin(np.abs(eta)))
    v = np.real(vecs[:, k])
    norm = v[1] ** 2 + v[2] ** 2 - 4 * v[0] * v[3]
    return v / np.sqrt(abs(norm)) if norm != 0 else v


def _residual(params, x, y):
    """Signed distance of (x, y) to the circle through (d n) tangent to phi with curvature k."""
    k, phi, d = params
    t = np.array([np.cos(phi), np.sin(phi)])
    n = np.array([-np.sin(phi), np.cos(phi)])
    ux, uy = x - d * n[0], y - d * n[1]
    ut, un = ux * t[0] + uy * t[1], ux * n[0] + uy * n[1]
    q = ut * ut + un * un
    return (k * q - 2.0 * un) / (1.0 + np.sqrt(np.maximum(1.0 + k * k * q - 2.0 * k * un, 0.0)))


def fit_circle(points) -> CircleFit:
    """Fit a circle to ``points`` (N, 2), N >= 3; curvature in 1 / the points' unit.

    The sign of the curvature is positive when the centre lies to the left of the direction
    of the points' principal axis taken from the first to the last point (well defined for
    arcs of less than half a turn).
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3:
        raise ValueError("a circle fit needs at least three (x, y) points")
    centre = p.mean(axis=0)
    x, y = (p - centre).T
    # Direction of the chord, oriented from the first to the last point.
    _, _, vt = np.linalg.svd(p - centre, full_matrices=False)
    axis = vt[0] if np.dot(vt[0], p[-1] - p[0]) >= 0 else -vt[0]
    phi0 = float(np.arctan2(axis[1], axis[0]))
    a, b, c, _ = _pratt(x, y)
    k0 = 2.0 * a
    # Orient the algebraic sign to the chord: centre (-B/2A, -C/2A) left of the axis -> k > 0.
    if a != 0:
        cx, cy = -b / (2 * a), -c / (2 * a)
        left = axis[0] * cy - axis[1] * cx > 0
        k0 = abs(k0) if left else -abs(k0)
    sol = least_squares(_residual, x0=[k0, phi0, 0.0], args=(x, y), method="lm")
    r = sol.fun
    dof = max(len(p) - 3, 1)
    s2 = float(r @ r) / dof
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * s2
        k_std = float(np.sqrt(max(cov[0, 0], 0.0)))
    except np.linalg.LinAlgError:
        k_std = float("inf")
    k = float(sol.x[0])
    # The refinement keeps phi near the chord direction; re-express k against the axis.
    if np.cos(sol.x[1] - phi0) < 0:
        k = -k
    return CircleFit(k, k_std, float(np.sqrt(np.mean(r * r))), len(p))
