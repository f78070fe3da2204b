"""Kinematics: contractor strain -> actuator outputs.

- contractor: the output is its axial strain (%).
- bending actuator: porous sections on a 1 mm strain-limiting base; a section strain ``eps``
  at a lever ``d`` from the neutral axis bends it to curvature ``efficiency * eps / d`` (1/m).
- 3-DoF segment: three contractors of height H at the corners of an equilateral triangle of
  side 52 mm (circumradius ``side / sqrt(3)``, angles 90, 210, 330 deg). Their shortenings
  ``dl_i = eps_i H`` define the platform plane ``dl(x, y) = dz + a x + b y``;
  ``dz`` (mm) is the shortening at the centre, ``theta_x = atan(b)`` (deg, positive when the
  +y corner shortens most) and ``theta_y = -atan(a)`` (deg, positive when the -x side
  shortens most).
"""

from __future__ import annotations

import math

import numpy as np

from porosense.sim.params import Geometry

CORNER_ANGLES_DEG = (90.0, 210.0, 330.0)


def bending_curvature(strain, g: Geometry):
    """Curvature (1/m) of the bending actuator at section strain ``strain`` (fraction)."""
    return g.bending_efficiency * np.asarray(strain) / (g.bending_lever_mm * 1e-3)


def corner_positions_mm(g: Geometry) -> np.ndarray:
    """(3, 2) x, y positions (mm) of the three contractors."""
    r = g.segment_side_mm / math.sqrt(3.0)
    a = np.radians(CORNER_ANGLES_DEG)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def _plane_solver(g: Geometry) -> np.ndarray:
    xy = corner_positions_mm(g)
    return np.linalg.inv(np.column_stack([np.ones(3), xy]))  # rows: dz, a, b from dl


def segment_pose(strain, g: Geometry):
    """theta_x (deg), theta_y (deg), dz (mm) for contractor strains ``strain`` (..., 3) (fraction)."""
    dl = np.asarray(strain, dtype=float) * g.segment_height_mm
    coef = dl @ _plane_solver(g).T
    dz, a, b = coef[..., 0], coef[..., 1], coef[..., 2]
    return np.degrees(np.arctan(b)), np.degrees(-np.arctan(a)), dz


class SegmentPose:
    """Precomputed plane solver for stepping one sample at a time."""

    def __init__(self, g: Geometry):
        self.m = _plane_solver(g).tolist()
        self.h = g.segment_height_mm

    def __call__(self, e0: float, e1: float, e2: float) -> tuple[float, float, float]:
        h = self.h
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self.m
        d0, d1, d2 = e0 * h, e1 * h, e2 * h
        dz = m00 * d0 + m01 * d1 + m02 * d2
        a = m10 * d0 + m11 * d1 + m12 * d2
        b = m20 * d0 + m21 * d1 + m22 * d2
        return math.degrees(math.atan(b)), math.degrees(-math.atan(a)), dz
