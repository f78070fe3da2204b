"""Measures the paper reports on its recordings: loop area, release overshoot, porosity law.

Used by the tests (the simulator must reproduce the paper) and by the sim benchmark.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import curve_fit

from porosense.data import Recording


def normalised_loop_area(x, y) -> float:
    """Area enclosed by the closed path (x, y) (shoelace), over the bounding box area (0..1)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    box = np.ptp(x) * np.ptp(y)
    return float(area / box) if box > 0 else 0.0


def transitions(rec: Recording, channel: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) the command turns on (0 -> vacuum) and off (vacuum -> 0) on ``channel``."""
    on = np.asarray(rec[f"p_cmd_{channel}"]) < 0
    edges = np.diff(on.astype(int))
    return rec.t[1:][edges == 1], rec.t[1:][edges == -1]


@dataclass
class Overshoot:
    """dR overshoot above R0 after one release: peak (%) and how much of it is gone (0..1)."""

    release_s: float
    peak_pct: float
    remaining_pct: float
    decayed: float

    def to_dict(self) -> dict:
        return asdict(self)


def release_overshoots(rec: Recording, channel: int = 0, window_s: float = 0.5) -> list[Overshoot]:
    """For each release: the dR peak before the next pulse (or the end) and its decay by then.

    The remaining overshoot is the mean dR over the last ``window_s`` before the next pulse.
    """
    ons, offs = transitions(rec, channel)
    dr = np.asarray(rec[f"dR_{channel}"], dtype=float)
    out = []
    for t_off in offs:
        later = ons[ons > t_off]
        t_end = later[0] if later.size else rec.t[-1] + rec.ts
        span = (rec.t >= t_off) & (rec.t < t_end)
        tail = (rec.t >= t_end - window_s) & (rec.t < t_end)
        peak = float(dr[span].max())
        remaining = float(dr[tail].mean())
        decayed = 1.0 - remaining / peak if peak > 0 else 0.0
        out.append(Overshoot(float(t_off), peak, remaining, decayed))
    return out


def hold_mean(
    rec: Recording, name: str, level_kpa: float, channel: int = 0, last_s: float = 2.0, occurrence: int = 0
) -> float:
    """Mean of ``name`` over the last ``last_s`` of a hold at ``level_kpa`` (the n-th such hold)."""
    at = np.isclose(rec[f"p_cmd_{channel}"], level_kpa)
    starts = np.flatnonzero(np.diff(np.r_[0, at.astype(int)]) == 1)
    ends = np.flatnonzero(np.diff(np.r_[at.astype(int), 0]) == -1)
    if occurrence >= len(starts):
        raise ValueError(f"no hold number {occurrence} at {level_kpa} kPa")
    a, b = starts[occurrence], ends[occurrence] + 1
    t_end = rec.t[b - 1]
    sel = slice(a, b)
    keep = rec.t[sel] > t_end - last_s
    return float(np.mean(np.asarray(rec[name][sel], dtype=float)[keep]))


@dataclass
class PowerLaw:
    """p = C (1 - phi/100)^n fitted over porosities, with its coefficient of determination."""

    C: float
    n: float
    r2: float

    def __call__(self, porosity):
        return self.C * (1.0 - np.asarray(porosity, dtype=float) / 100.0) ** self.n

    def to_dict(self) -> dict:
        return asdict(self)


def fit_power_law(porosity, values) -> PowerLaw:
    """Least-squares fit of ``C (1 - phi/100)^n`` to ``values`` (R^2 on the values)."""
    rho = 1.0 - np.asarray(porosity, dtype=float) / 100.0
    v = np.asarray(values, dtype=float)
    sign = np.sign(v.mean())
    slope, icpt = np.polyfit(np.log(rho), np.log(np.abs(v)), 1)
    (c, n), _ = curve_fit(lambda r, c, n: c * r**n, rho, v, p0=(sign * np.exp(icpt), slope), maxfev=10000)
    resid = v - c * rho**n
    r2 = 1.0 - float(np.sum(resid**2) / np.sum((v - v.mean()) ** 2))
    return PowerLaw(float(c), float(n), r2)
