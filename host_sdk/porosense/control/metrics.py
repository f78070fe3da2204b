"""How well a run followed its targets: tracking error, settling, overshoot, steady-state error.

Errors are ``output - target`` in output units (for the contractor, % strain), measured against
the true output where the back-end knows it (the simulator's strain), else the estimate.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from porosense.control.tuning import settling_and_overshoot

#: Share of each hold, at its end, over which the steady-state error is averaged.
STEADY_TAIL = 0.25


@dataclass
class TrackingMetrics:
    """RMS and peak error (output units and % of the largest |target|) over the samples where a
    target was set, with ``n`` samples."""

    rms: float
    peak: float
    rms_pct_of_target: float
    peak_pct_of_target: float
    n: int

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class StepMetrics:
    """One constant target held from ``t0_s`` for ``hold_s``: settling time (s, 2 % band of the
    step, NaN when it did not settle), overshoot (% of the step) and the steady-state error
    (mean of output - target over the hold's last quarter, output units)."""

    target: float
    start: float
    t0_s: float
    hold_s: float
    settling_s: float
    overshoot_pct: float
    steady_error: float

    def to_dict(self) -> dict:
        return asdict(self)


def tracking_metrics(target, output, *, skip: np.ndarray | None = None) -> TrackingMetrics:
    """Error statistics of ``output`` against ``target`` (arrays, NaN target = not controlling;
    ``skip``: boolean mask of samples left out, e.g. the first seconds of a step)."""
    target = np.asarray(target, dtype=float)
    output = np.asarray(output, dtype=float)
    use = np.isfinite(target) & np.isfinite(output)
    if skip is not None:
        use &= ~np.asarray(skip, dtype=bool)
    if not use.any():
        nan = float("nan")
        return TrackingMetrics(nan, nan, nan, nan, 0)
    e = output[use] - target[use]
    scale = float(np.max(np.abs(target[use])))
    rms = float(np.sqrt(np.mean(e * e)))
    peak = float(np.max(np.abs(e)))
    pct = (lambda x: 100.0 * x / scale) if scale > 0 else (lambda x: float("nan"))
    return TrackingMetrics(rms, peak, pct(rms), pct(peak), int(use.sum()))


def step_metrics(t, target, output, t0_s: float, hold_s: float, start: float) -> StepMetrics:
    """Metrics of the hold of the constant ``target`` over [t0_s, t0_s + hold_s) (s), coming from
    ``start`` (output units: the target or output before the step)."""
    t = np.asarray(t, dtype=float)
    output = np.asarray(output, dtype=float)
    sel = (t >= t0_s) & (t < t0_s + hold_s)
    tt, yy = t[sel], output[sel]
    if tt.size < 4:
        nan = float("nan")
        return StepMetrics(float(target), float(start), t0_s, hold_s, nan, nan, nan)
    step = float(target) - float(start)
    if step != 0:
        settling, over = settling_and_overshoot(tt - t0_s, yy - start, step)
    else:
        settling, over = float("nan"), float("nan")
    k = int(tt.size * (1.0 - STEADY_TAIL))
    steady = float(np.mean(yy[k:]) - target)
    return StepMetrics(float(target), float(start), float(t0_s), float(hold_s), settling, over, steady)
