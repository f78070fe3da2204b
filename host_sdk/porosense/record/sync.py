"""Place video frames on the board's clock from the sync indicator's blinks.

The board switches its indicator at known device times (:mod:`porosense.record.blinks`); the
camera sees the switches as brightness steps between frames. Each observed edge is timed to a
fraction of a frame by where the brightness crosses half way, matched to the board's edge of
the same polarity, and a straight line ``t_dev = offset + (1 + drift) t_cam`` is fitted by
least squares. Without visible blinks, :func:`host_clock` aligns by host timestamps instead.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from porosense.errors import InputError
from porosense.record.blinks import PULSE_MS, board_edges

#: Smallest on/off brightness step (grey levels) taken as a visible indicator.
MIN_STEP = 20.0
#: Edges spanning less than this (s) fix the offset only; the drift stays 0.
MIN_DRIFT_SPAN_S = 10.0


@dataclass
class ClockFit:
    """Camera -> device time: ``t_dev = offset_s + (1 + drift_ppm 1e-6) t_cam`` (s).

    ``t_dev`` counts from the board's first sample; ``residual_ms`` is the rms of the matched
    edges about the line, ``expected_error_ms`` what the method can promise.
    """

    offset_s: float
    drift_ppm: float
    residual_ms: float
    n_edges: int
    method: str  # "blinks" or "host"
    expected_error_ms: float

    def to_dev(self, t_cam) -> np.ndarray:
        return self.offset_s + (1.0 + self.drift_ppm * 1e-6) * np.asarray(t_cam, dtype=float)

    def to_cam(self, t_dev) -> np.ndarray:
        return (np.asarray(t_dev, dtype=float) - self.offset_s) / (1.0 + self.drift_ppm * 1e-6)

    def to_dict(self) -> dict:
        return asdict(self)

    def __str__(self) -> str:
        return (
            f"clock by {self.method}: offset {self.offset_s:.4f} s, drift {self.drift_ppm:.0f} ppm, "
            f"residual {self.residual_ms:.1f} ms over {self.n_edges} edges"
        )


def observed_edges(t_cam, brightness) -> tuple[np.ndarray, np.ndarray] | None:
    """Camera times (s) and polarities of the indicator's switches; None when it never blinks."""
    b = np.asarray(brightness, dtype=float)
    t = np.asarray(t_cam, dtype=float)
    if b.size < 3:
        return None
    lo = float(np.median(b))
    top = b > (lo + b.max()) / 2.0
    if not top.any():
        return None
    hi = float(np.median(b[top]))
    if hi - lo < MIN_STEP:
        return None
    x = (b - lo) / (hi - lo)
    on = x > 0.5
    k = np.flatnonzero(on[1:] != on[:-1]) + 1
    x0, x1 = x[k - 1], x[k]
    frac = np.clip((0.5 - x0) / np.where(x1 != x0, x1 - x0, 1.0), 0.0, 1.0)
    return t[k - 1] + frac * (t[k] - t[k - 1]), np.where(on[k], 1, -1)


def _match(tc, pc, td, pd, offset, slope, tol):
    """Pairs (i observed, j board) whose mapped times agree within ``tol`` (s), same polarity."""
    mapped = offset + slope * tc
    j = np.clip(np.searchsorted(td, mapped), 1, len(td) - 1)
    j = np.where(np.abs(td[j - 1] - mapped) < np.abs(td[j] - mapped), j - 1, j)
    ok = (np.abs(td[j] - mapped) < tol) & (pd[j] == pc)
    return np.flatnonzero(ok), j[ok]


def fit_clock(t_cam, brightness, t_dev_us, fps: float) -> ClockFit | None:
    """Fit camera -> device time from the indicator ``brightness`` per frame; None if no blinks.

    ``t_dev_us``: the board's sample times (us) from the stream's first sample on.
    """
    seen = observed_edges(t_cam, brightness)
    if seen is None or seen[0].size == 0:
        return None
    tc, pc = seen
    td, pd = board_edges(t_dev_us)
    if td.size < 2:
        return None
    tol = PULSE_MS * 1e-3 / 2
    t_cam = np.asarray(t_cam, dtype=float)
    # Coarse: every pairing of an observed with a board rising edge is a candidate offset;
    # score = matched edges minus board edges inside the video that were not seen.
    rising_c, rising_d = tc[pc > 0], td[pd > 0]
    scored = []
    for o in np.unique(np.round((rising_d[None, :] - rising_c[:, None]).ravel(), 4)):
        i, _ = _match(tc, pc, td, pd, o, 1.0, tol)
        inside = (td >= o + t_cam[0]) & (td <= o + t_cam[-1])
        scored.append((2 * len(i) - int(inside.sum()), float(o)))
    if not scored:
        return None
    scored.sort(reverse=True)
    best = scored[0]
    rivals = [o for sc, o in scored[1:] if sc == best[0] and abs(o - best[1]) > PULSE_MS * 1e-3]
    if rivals:
        raise InputError(
            f"the sync blinks fit offsets {best[1]:.2f} s and {rivals[0]:.2f} s equally well: the video "
            "must show the start code (start the camera before the stream)"
        )
    offset, slope = best[1], 1.0
    i = j = np.zeros(0, int)
    for tol_k in (tol, 3.0 / fps, 1.5 / fps):
        i, j = _match(tc, pc, td, pd, offset, slope, tol_k)
        if len(i) < 2:
            return None
        if np.ptp(tc[i]) >= MIN_DRIFT_SPAN_S:
            slope, offset = np.polyfit(tc[i], td[j], 1)
        else:
            slope, offset = 1.0, float(np.mean(td[j] - tc[i]))
    res = td[j] - (offset + slope * tc[i])
    rms = float(np.sqrt(np.mean(res**2)))
    return ClockFit(
        float(offset),
        float((slope - 1.0) * 1e6),
        rms * 1e3,
        int(len(i)),
        "blinks",
        max(rms * 1e3, 1e3 / fps / np.sqrt(12.0)),
    )


def host_clock(t_host_stream_start: float, expected_error_ms: float) -> ClockFit:
    """Fallback for frames timed by the host clock (s): device time = frame time minus the host
    time of the stream's first sample (same clock); ``expected_error_ms`` is stated, not fitted."""
    return ClockFit(-float(t_host_stream_start), 0.0, float("nan"), 0, "host", float(expected_error_ms))
