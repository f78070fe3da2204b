"""Tracked values resampled on the board's sample times: the Recording's truth columns."""

from __future__ import annotations

import numpy as np

from porosense.data import Recording
from porosense.errors import InputError
from porosense.record.sync import ClockFit
from porosense.record.tracker import Track, format_ranges, frame_ranges


def _device_time_s(board: Recording) -> np.ndarray:
    if "t_dev_us" in board:
        t_us = np.asarray(board["t_dev_us"], dtype=float)
        return (t_us - t_us[0]) * 1e-6
    return board.t - board.t[0]


def _resample(t_frames, values, ok, t_query) -> np.ndarray:
    """Linear interpolation between the two frames around each time; NaN if either failed."""
    k = np.clip(np.searchsorted(t_frames, t_query, side="right") - 1, 0, len(t_frames) - 2)
    t0, t1 = t_frames[k], t_frames[k + 1]
    w = np.clip((t_query - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0, 1.0)
    out = (1 - w) * values[k] + w * values[k + 1]
    good = ok[k] & ok[k + 1]
    out[~good] = np.nan
    return out


def add_truth(board: Recording, track: Track, clock: ClockFit, *, marker_length_mm=None) -> Recording:
    """``board`` with the camera's truth added: ``curvature`` (1/m), ``dz`` (mm), ``strain_0``
    (%, when ``marker_length_mm`` is known), ``t_cam`` (s, the camera time of each sample) and
    ``camera_ok`` (1 where every truth value came from two good frames, else 0 and NaN).
    """
    t_dev = _device_time_s(board)
    t_cam = clock.to_cam(t_dev)
    frames = track.t_cam
    half = 0.5 / track.fps if track.fps > 0 else 0.0
    if t_cam[0] < frames[0] - half or t_cam[-1] > frames[-1] + half:
        span_v = clock.to_dev(frames[[0, -1]])
        short = max(float(span_v[0] - t_dev[0]), float(t_dev[-1] - span_v[1]))
        raise InputError(
            f"the video covers device time {span_v[0]:.2f} to {span_v[1]:.2f} s but the recording "
            f"spans {t_dev[0]:.2f} to {t_dev[-1]:.2f} s: the video is {short:.2f} s too short"
        )
    cols, units = {"t_cam": t_cam}, {"t_cam": "s"}
    good = np.ones(t_dev.size, dtype=bool)
    if track.curvature is not None:
        cols["curvature"] = _resample(frames, track.curvature, track.ok_stripes, t_cam)
        cols["curvature_std"] = _resample(frames, track.curvature_std, track.ok_stripes, t_cam)
        units["curvature"] = units["curvature_std"] = "1/m"
        good &= np.isfinite(cols["curvature"])
    if track.dz_mm is not None:
        cols["dz"] = _resample(frames, track.dz_mm, track.ok_marker, t_cam)
        units["dz"] = "mm"
        if marker_length_mm:
            cols["strain_0"] = cols["dz"] / float(marker_length_mm) * 100.0
            units["strain_0"] = "%"
        good &= np.isfinite(cols["dz"])
    cols["camera_ok"] = good.astype(np.int64)
    units["camera_ok"] = "flag"
    name_clash = [n for n in cols if n in board.columns]
    merged = dict(board.columns)
    for name, values in cols.items():
        merged[f"{name}_camera" if name in name_clash else name] = values
    meta = dict(board.meta)
    meta["camera"] = {
        "clock": clock.to_dict(),
        "track": track.to_dict(),
        "samples_without_truth": int((~good).sum()),
        "sample_ranges_without_truth": format_ranges(frame_ranges(~good)),
        "truth_columns": [n for n in ("curvature", "dz", "strain_0") if n in cols],
    }
    return Recording(board.t, merged, meta=meta, units={**board.units, **units})


def frame_table(track: Track, clock: ClockFit) -> Recording:
    """The camera's own samples: one row per frame at camera time ``t`` (s), with its device
    time ``t_dev`` (s), the tracked values (NaN where failed) and the ok flags."""
    cols, units = {"t_dev": clock.to_dev(track.t_cam)}, {"t_dev": "s"}
    if track.indicator is not None:
        cols["indicator"], units["indicator"] = track.indicator, "grey"
    if track.curvature is not None:
        cols["curvature"], units["curvature"] = track.curvature, "1/m"
        cols["curvature_std"], units["curvature_std"] = track.curvature_std, "1/m"
        cols["stripes_ok"], units["stripes_ok"] = track.ok_stripes.astype(np.int64), "flag"
    if track.dz_mm is not None:
        cols["dz"], units["dz"] = track.dz_mm, "mm"
        cols["marker_ok"], units["marker_ok"] = track.ok_marker.astype(np.int64), "flag"
    return Recording(track.t_cam, cols, meta={"camera": track.to_dict(), "clock": clock.to_dict()}, units=units)
