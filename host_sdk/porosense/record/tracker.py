"""Track a video: curvature from the stripes, marker displacement dz, indicator brightness.

Every frame is measured independently. A frame where a target is not found (wrong stripe
count, marker missing or of the wrong size) is flagged and its value left NaN, never filled;
more failed frames than the layout's ``max_failed_fraction`` is an error naming the ranges.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from porosense.errors import InputError
from porosense.record.calibration import Calibration
from porosense.record.circle import fit_circle
from porosense.record.detect import dark_blobs
from porosense.record.layout import Layout
from porosense.record.video import open_video

#: Frames at the start used to learn the stripe count, the marker size and the scale.
LEARN_FRAMES = 30
#: A marker blob whose area is off the typical one by more than this factor is not the marker
#: (a half-hidden marker's centroid is off by a third of its diameter).
MARKER_AREA_FACTOR = 1.5
#: A feature darker than this share of the typical feature's contrast is a shadow, not ink.
MIN_CONTRAST_SHARE = 0.5


def frame_ranges(bad: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive (first, last) frame index ranges where ``bad`` is true."""
    idx = np.flatnonzero(np.asarray(bad, dtype=bool))
    if idx.size == 0:
        return []
    cut = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[cut + 1]]
    ends = np.r_[idx[cut], idx[-1]]
    return list(zip(starts.tolist(), ends.tolist()))


def format_ranges(ranges, limit: int = 8) -> str:
    text = ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in ranges[:limit])
    return text + (f" and {len(ranges) - limit} more" if len(ranges) > limit else "")


@dataclass
class Track:
    """Per-frame results: camera time (s), curvature (1/m) and its std, dz (mm), indicator.

    NaN marks a frame where that target failed; ``ok_stripes`` / ``ok_marker`` say which.
    """

    t_cam: np.ndarray
    indicator: np.ndarray | None = None
    curvature: np.ndarray | None = None
    curvature_std: np.ndarray | None = None
    ok_stripes: np.ndarray | None = None
    dz_mm: np.ndarray | None = None
    ok_marker: np.ndarray | None = None
    mm_per_px: float | None = None
    fps: float = float("nan")
    tracking_fps: float = float("nan")  # frames per wall-clock second (decode included)
    tracking_fps_cpu: float = float("nan")  # frames per CPU second of this process
    stripe_count: int = 0
    info: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.t_cam.size)

    def failed_ranges(self) -> dict:
        out = {}
        if self.ok_stripes is not None:
            out["stripes"] = frame_ranges(~self.ok_stripes)
        if self.ok_marker is not None:
            out["marker"] = frame_ranges(~self.ok_marker)
        return out

    def to_dict(self) -> dict:
        return {
            "n_frames": self.n_frames,
            "fps": self.fps,
            "tracking_fps": self.tracking_fps,
            "tracking_fps_cpu": self.tracking_fps_cpu,
            "mm_per_px": self.mm_per_px,
            "stripe_count": self.stripe_count,
            "failed_frames": {k: [list(r) for r in v] for k, v in self.failed_ranges().items()},
            **self.info,
        }

    def __repr__(self) -> str:
        failed = {k: int(sum(b - a + 1 for a, b in v)) for k, v in self.failed_ranges().items()}
        return (
            f"Track({self.n_frames} frames at {self.fps:.2f} fps, tracked at "
            f"{self.tracking_fps:.0f} fps, failed frames {failed})"
        )


class _Scale:
    """Pixels -> mm: a checkerboard calibration, else a reference length in view."""

    def __init__(self, layout: Layout, calibration: Calibration | None):
        self.cal = calibration
        self.mm_per_px = None
        self.layout = layout
        self._ref = []

    def learn(self, gray) -> None:
        if self.cal is not None or self.layout.reference is None:
            return
        blobs = dark_blobs(gray, self.layout.reference, self.layout.feature_px, self.layout.min_contrast)
        blobs = sorted(blobs, key=lambda b: -b.contrast)  # the dots are ink: the darkest
        if len(blobs) >= 2:
            self._ref.append(float(np.hypot(blobs[0].x - blobs[1].x, blobs[0].y - blobs[1].y)))

    def finish(self) -> None:
        if self.cal is not None:
            return
        if self.layout.reference is None:
            raise InputError("no scale: give 'reference' and 'reference_mm' in the layout, or --calibration")
        if not self._ref:
            raise InputError(f"reference: two dots not found in region {list(self.layout.reference)}")
        self.mm_per_px = float(self.layout.reference_mm) / float(np.median(self._ref))

    def to_mm(self, pts) -> np.ndarray:
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        return self.cal.to_mm(pts) if self.cal is not None else pts * self.mm_per_px


def _stripe_points(gray, layout: Layout) -> np.ndarray:
    blobs = dark_blobs(gray, layout.stripes, layout.feature_px, layout.min_contrast)
    if not blobs:
        return np.zeros((0, 2))
    # Stripe fragments (a partly hidden stripe) are far smaller than the stripes themselves.
    typical = np.median([b.area for b in blobs])
    ink = max(b.contrast for b in blobs)
    return np.array(
        [(b.x, b.y) for b in blobs if b.area >= 0.5 * typical and b.contrast >= MIN_CONTRAST_SHARE * ink]
    ).reshape(-1, 2)


def _marker_blob(gray, layout: Layout):
    blobs = dark_blobs(gray, layout.marker, layout.feature_px, layout.min_contrast)
    return max(blobs, key=lambda b: b.contrast) if blobs else None  # ink is the darkest


def _indicator(gray, layout: Layout) -> float:
    x, y, w, h = layout.indicator
    return float(gray[y : y + h, x : x + w].mean())


def track_video(
    path,
    layout: Layout,
    calibration: Calibration | None = None,
    *,
    timestamps=None,
    progress: bool = False,
    preview=None,
) -> Track:
    """Track ``path`` (a video file) with ``layout``; camera times from ``timestamps`` (s, one
    per frame, e.g. host capture times) or frame index / fps. ``preview``: write an annotated
    copy of the video there.
    """
    cap, fps, n_hint = open_video(path)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_hint or None, desc="  tracking", unit="frame", leave=False, dynamic_ncols=True)
    scale = _Scale(layout, calibration)
    indicator, stripes, marker = [], [], []
    writer = None
    t_start, cpu_start = time.perf_counter(), time.process_time()
    k = 0
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
            if k == 0:
                _check_regions(layout, gray.shape, path)
            if k < LEARN_FRAMES:
                scale.learn(gray)
            if layout.indicator is not None:
                indicator.append(_indicator(gray, layout))
            if layout.stripes is not None:
                stripes.append(_stripe_points(gray, layout))
            if layout.marker is not None:
                marker.append(_marker_blob(gray, layout))
            if preview is not None:
                writer = _annotate(writer, preview, frame, fps, layout, stripes, marker)
            k += 1
            if bar is not None:
                bar.update(1)
    finally:
        cap.release()
        if bar is not None:
            bar.close()
        if writer is not None:
            writer.release()
    elapsed, cpu = time.perf_counter() - t_start, time.process_time() - cpu_start
    n = k
    if timestamps is not None:
        t_cam = np.asarray(timestamps, dtype=float)[:n]
        if t_cam.size < n:
            raise InputError(f"{len(timestamps)} timestamps for {n} frames of {path}")
    else:
        t_cam = np.arange(n) / fps
    scale.finish()
    track = Track(
        t_cam=t_cam,
        fps=fps,
        tracking_fps=n / elapsed if elapsed > 0 else float("inf"),
        tracking_fps_cpu=n / cpu if cpu > 0 else float("inf"),
        mm_per_px=scale.mm_per_px,
    )
    if layout.indicator is not None:
        track.indicator = np.asarray(indicator)
    if layout.stripes is not None:
        _curvature(track, stripes, scale, layout, path)
    if layout.marker is not None:
        _displacement(track, marker, scale, layout, path)
    _check_failures(track, layout, path)
    return track


def _check_regions(layout: Layout, shape, path) -> None:
    h, w = shape[:2]
    for name in ("stripes", "marker", "indicator", "reference"):
        roi = getattr(layout, name)
        if roi is not None and (roi[0] < 0 or roi[1] < 0 or roi[0] + roi[2] > w or roi[1] + roi[3] > h):
            raise InputError(f"layout region '{name}' {list(roi)} lies outside the {w}x{h} frames of {path}")


def _curvature(track: Track, stripes, scale: _Scale, layout: Layout, path) -> None:
    counts = np.array([len(p) for p in stripes])
    learn = counts[:LEARN_FRAMES]
    expected = int(np.bincount(learn).argmax()) if learn.size else 0
    if expected < 3:
        raise InputError(
            f"{path}: fewer than three stripes found in region {list(layout.stripes)} "
            f"(found {expected}); the curvature needs at least three"
        )
    n = len(stripes)
    kappa, kstd = np.full(n, np.nan), np.full(n, np.nan)
    ok = counts == expected
    axis = None
    for i in np.flatnonzero(ok):
        pts = scale.to_mm(stripes[i])
        centre = pts.mean(axis=0)
        if axis is None:  # one ordering direction for the whole video: a consistent sign
            axis = np.linalg.svd(pts - centre, full_matrices=False)[2][0]
        pts = pts[np.argsort((pts - centre) @ axis)]
        fit = fit_circle(pts)
        kappa[i], kstd[i] = fit.curvature * 1000.0, fit.curvature_std * 1000.0  # 1/mm -> 1/m
    # Positive in the direction the actuator bends (the larger excursion).
    if np.any(ok) and abs(np.nanpercentile(kappa, 1)) > abs(np.nanpercentile(kappa, 99)):
        kappa = -kappa
    track.curvature, track.curvature_std, track.ok_stripes = kappa, kstd, ok
    track.stripe_count = expected


def _displacement(track: Track, marker, scale: _Scale, layout: Layout, path) -> None:
    n = len(marker)
    found = np.array([b is not None for b in marker])
    if not found.any():
        raise InputError(f"{path}: no marker found in region {list(layout.marker)} in any of {n} frames")
    areas = np.array([b.area if b is not None else np.nan for b in marker])
    contrast = np.array([b.contrast if b is not None else np.nan for b in marker])
    learn = np.isfinite(areas[:LEARN_FRAMES]).any()
    typical = np.nanmedian(areas[:LEARN_FRAMES] if learn else areas)
    ink = np.nanmedian(contrast[:LEARN_FRAMES] if learn else contrast)
    with np.errstate(invalid="ignore"):
        ok = (
            found
            & (areas < typical * MARKER_AREA_FACTOR)
            & (areas > typical / MARKER_AREA_FACTOR)
            & (contrast > MIN_CONTRAST_SHARE * ink)
        )
    px = np.array([(b.x, b.y) if b is not None else (np.nan, np.nan) for b in marker])
    if not ok.any():
        raise InputError(
            f"{path}: no marker found in region {list(layout.marker)}: dark blobs there "
            "change size or contrast from frame to frame"
        )
    mm = np.full((n, 2), np.nan)
    mm[ok] = scale.to_mm(px[ok])
    # Rest position: the first second of video (the schedule starts at rest).
    first = ok & (track.t_cam - track.t_cam[0] < 1.0)
    if not first.any():
        first = ok
    rest = np.median(mm[first], axis=0)
    d = mm - rest
    # Axis of motion: principal direction of the displacements (absorbs the camera's roll).
    axis = np.linalg.svd(d[ok], full_matrices=False)[2][0]
    dz = d @ axis
    if abs(np.nanpercentile(dz, 1)) > abs(np.nanpercentile(dz, 99)):
        dz = -dz  # positive when the contractor shortens (its larger excursion)
    dz[~ok] = np.nan
    track.dz_mm, track.ok_marker = dz, ok


def _check_failures(track: Track, layout: Layout, path) -> None:
    for name, ranges in track.failed_ranges().items():
        n_bad = sum(b - a + 1 for a, b in ranges)
        if n_bad > layout.max_failed_fraction * track.n_frames:
            raise InputError(
                f"{path}: {name} not found in {n_bad} of {track.n_frames} frames "
                f"(more than {layout.max_failed_fraction:.0%}): frames {format_ranges(ranges)}"
            )


def _annotate(writer, path, frame, fps, layout: Layout, stripes, marker):
    """Draw the regions and detections on a copy of ``frame`` and append it to ``path``."""
    img = frame.copy() if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    if writer is None:
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, img.shape[1::-1])
    for name, colour in (
        ("stripes", (0, 200, 0)),
        ("marker", (0, 0, 255)),
        ("indicator", (0, 200, 255)),
        ("reference", (255, 0, 0)),
    ):
        roi = getattr(layout, name)
        if roi is not None:
            x, y, w, h = roi
            cv2.rectangle(img, (x, y), (x + w, y + h), colour, 1)
    if stripes:
        for x, y in stripes[-1]:
            cv2.circle(img, (int(round(x)), int(round(y))), 4, (0, 200, 0), 1)
    if marker and marker[-1] is not None:
        cv2.drawMarker(img, (int(round(marker[-1].x)), int(round(marker[-1].y))), (0, 0, 255), cv2.MARKER_CROSS, 12, 1)
    writer.write(img)
    return writer
