"""Calibrate the actuator simulator to measured data, so that diagnosis can say what it misses.

Commanded vacuum goes in (columns ``p_cmd_0..2``, kPa), a measured column comes out (``dR_*``,
``strain_*``, ``curvature``, ``theta_x``, ``theta_y`` or ``dz``). Calibrated parameters:

* ``porosity`` (%, 60..90): the physical parameter that sets stroke and sensitivity
  (bounded scalar search, scipy.optimize.minimize_scalar);
* ``scale`` and ``offset`` of the output (sensor sensitivity and zero, in the output's unit):
  linear least squares inside every evaluation.

Samples piled up exactly at a record's extreme (at least 10, a clipped ADC or divider) are
left out of the calibration cost: they only say that the output is beyond the limit.

The simulation runs without noise and without any named effect: it is the nominal physics,
and what it misses is what diagnosis is asked to find.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import optimize

from porosense.errors import InputError

POROSITY_BOUNDS = (60.0, 90.0)


@dataclass
class Calibration:
    """Calibrated simulator: actuator, porosity (%), output scale and offset, fit (%) on the
    estimation samples it was calibrated on (clipped samples left out)."""

    actuator: str
    output: str
    porosity: float
    scale: float
    offset: float
    fit_estimation: float
    #: the simulator's stage parameters (porosense.sim.Physics; None: the defaults), not saved
    physics: object = field(default=None, repr=False, compare=False)

    def predict(self, p_cmd: np.ndarray, ts: float) -> np.ndarray:
        """Simulated output for commanded vacuum p_cmd (N, n_channels) kPa, sampled every ts s."""
        return self.scale * _simulate(self.actuator, self.output, self.porosity, p_cmd, ts, self.physics) + self.offset

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("physics")
        return d


def _simulate(actuator: str, output: str, porosity: float, p_cmd: np.ndarray, ts: float, physics=None) -> np.ndarray:
    from porosense import sim

    p = np.asarray(p_cmd, float).reshape(len(p_cmd), -1)
    sp = np.zeros((len(p), 3))
    sp[:, : p.shape[1]] = np.minimum(p, 0.0)
    on = sp < 0.0
    plant = sim.make_plant(actuator, porosity=porosity, noise=False, physics=physics)
    out = plant.run(ts, sp, on, on.copy())
    if output not in out:
        raise InputError(
            f"the {actuator} simulator has no output '{output}' "
            f"(it has {', '.join(k for k in out if not k.startswith(('voltage', 'euler', 't_')))})"
        )
    return np.asarray(out[output], float)  # sample k as a recording stores it


def _at_limit(y: np.ndarray, min_count: int = 10) -> np.ndarray:
    """Samples exactly at the record's minimum or maximum when at least ``min_count`` sit there."""
    tol = 1e-6 * (float(np.ptp(y)) or 1.0)
    out = np.zeros(len(y), bool)
    for ext in (y.min(), y.max()):
        at = np.abs(y - ext) <= tol
        if at.sum() >= min_count:
            out |= at
    return out


def calibrate(actuator: str, output: str, u_list: list, y_list: list, ts: float, physics=None) -> Calibration:
    """Fit porosity, scale and offset of ``actuator``'s ``output`` to the estimation records.

    ``physics`` (porosense.sim.Physics or None for the defaults) is the simulator calibrated."""
    from porosense.dsp.metrics import fit_percent

    ys = np.concatenate([np.asarray(y, float) for y in y_list])
    # samples piled up exactly at a record's extreme are clipped (ADC or divider limit): they
    # say only that the output is beyond the limit, so they do not pull the calibration
    keep = np.concatenate([~_at_limit(np.asarray(y, float)) for y in y_list])
    if keep.sum() < 10:
        keep[:] = True

    def affine(por):
        sims = np.concatenate([_simulate(actuator, output, por, u, ts, physics) for u in u_list])
        X = np.column_stack([sims, np.ones_like(sims)])
        coef, *_ = np.linalg.lstsq(X[keep], ys[keep], rcond=None)
        return coef, X @ coef

    def cost(por):
        return float(np.sum((ys - affine(por)[1])[keep] ** 2))

    grid = np.linspace(*POROSITY_BOUNDS, 7)
    costs = [cost(p) for p in grid]
    k = int(np.argmin(costs))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    sol = optimize.minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 0.05})
    por = float(sol.x) if sol.fun <= costs[k] else float(grid[k])
    (scale, offset), pred = affine(por)
    return Calibration(actuator, output, por, float(scale), float(offset), fit_percent(ys[keep], pred[keep]), physics)
