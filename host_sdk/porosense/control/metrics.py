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
    """Tracking error over the samples where a target was set (error = output - target).

    Attributes
    ----------
    rms, peak : float
        RMS and largest |error|, output units (nan when no sample counted).
    rms_pct_of_target, peak_pct_of_target : float
        The same, % of the largest |target|.
    n : int
        Samples counted.
    """

    rms: float
    peak: float
    rms_pct_of_target: float
    peak_pct_of_target: float
    n: int

    def to_dict(self) -> dict:
        """The fields as a plain dict.

        Returns
        -------
        dict
            JSON-ready.
        """
        return asdict(self)


@dataclass
class StepMetrics:
    """How one constant target, held from ``t0_s`` for ``hold_s``, was reached.

    Attributes
    ----------
    target : float
        The held target, output units.
    start : float
        Target or output before the step, output units.
    t0_s, hold_s : float
        Start and length of the hold, s.
    settling_s : float
        Settling time in the 2 % band of the step, s from ``t0_s`` (nan when it did not settle).
    overshoot_pct : float
        Overshoot, % of the step.
    steady_error : float
        Mean of output - target over the hold's last quarter, output units.
    """

    target: float
    start: float
    t0_s: float
    hold_s: float
    settling_s: float
    overshoot_pct: float
    steady_error: float

    def to_dict(self) -> dict:
        """The fields as a plain dict.

        Returns
        -------
        dict
            JSON-ready.
        """
        return asdict(self)


def tracking_metrics(target, output, *, skip: np.ndarray | None = None) -> TrackingMetrics:
    """Error statistics of ``output`` against ``target``.

    Parameters
    ----------
    target : array_like
        Target per sample, output units; NaN where nothing was controlled.
    output : array_like
        Output per sample (true or estimated), output units.
    skip : ndarray of bool or None
        Samples left out (e.g. the first seconds of a step).

    Returns
    -------
    TrackingMetrics
        RMS and peak error over the samples with a finite target and output.
    """
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
    """Metrics of the hold of the constant ``target`` over [t0_s, t0_s + hold_s).

    Parameters
    ----------
    t : array_like
        Time per sample, s.
    target : float
        The held target, output units.
    output : array_like
        Output per sample, output units.
    t0_s, hold_s : float
        Start and length of the hold, s.
    start : float
        Target or output before the step, output units.

    Returns
    -------
    StepMetrics
        Settling time, overshoot and steady-state error (nan when the hold has fewer than 4
        samples).
    """
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
