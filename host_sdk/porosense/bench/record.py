"""``porosense bench record``: track rendered videos of simulated actuators against their truth.

The renderer lives with the tests (tests/record/render.py, independent of the tracker), so
this benchmark needs the source tree. Per seed it renders a video, tracks it, fits the clock
from the sync blinks and compares with the simulator's true curvature, stroke and clock.
"""

from __future__ import annotations

import importlib.util
import sys
import tempfile
from pathlib import Path

import numpy as np

from porosense.errors import InputError
from porosense.record.layout import Layout
from porosense.record.sync import fit_clock
from porosense.record.tracker import track_video
from porosense.record.truth import add_truth

RENDERER = Path(__file__).resolve().parents[3] / "tests" / "record" / "render.py"


def load_renderer():
    """The test renderer module, imported from the source tree."""
    if not RENDERER.is_file():
        raise InputError(f"the record benchmark needs the renderer {RENDERER} (a source checkout)")
    spec = importlib.util.spec_from_file_location("porosense_test_render", RENDERER)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def measure(scene) -> dict:
    """Track ``scene`` (a rendered video) and compare with its truth; figures as a dict."""

    layout = Layout(**scene.layout)
    track = track_video(scene.video, layout)
    clock = fit_clock(track.t_cam, track.indicator, scene.board["t_dev_us"], track.fps)
    if clock is None:
        raise InputError("no sync blinks found in the rendered video")
    rec = add_truth(scene.board, track, clock, marker_length_mm=layout.marker_length_mm)
    ok = rec["camera_ok"] > 0
    k_err = rec["curvature"][ok] - scene.truth_curvature[ok]
    dz_err = rec["dz"][ok] - scene.truth_dz[ok]
    t_frames = track.t_cam
    offset_frames = np.abs(clock.to_dev(t_frames) - scene.true_dev_time(t_frames)) * scene.fps
    return {
        "curvature_rms_pct_of_max": float(100.0 * np.sqrt(np.mean(k_err**2)) / np.max(np.abs(scene.truth_curvature))),
        "curvature_max_1_per_m": float(np.max(np.abs(scene.truth_curvature))),
        "dz_rms_mm": float(np.sqrt(np.mean(dz_err**2))),
        "dz_max_mm": float(np.max(np.abs(scene.truth_dz))),
        "sync_offset_frames_max": float(offset_frames.max()),
        "sync_offset_frames_mean": float(offset_frames.mean()),
        "sync_residual_ms": clock.residual_ms,
        "sync_edges": clock.n_edges,
        "drift_ppm_error": float(clock.drift_ppm - scene.drift_ppm),
        "samples_without_truth": int((~ok).sum()),
        "frames_failed": {k: int(sum(b - a + 1 for a, b in v)) for k, v in track.failed_ranges().items()},
        "frames_occluded": len(scene.occluded),
        "tracking_fps": track.tracking_fps,
        "tracking_fps_cpu": track.tracking_fps_cpu,
        "n_frames": track.n_frames,
    }


def run(size: str) -> dict:
    render = load_renderer()
    seeds = range(2) if size == "small" else range(5)
    per_seed = []
    with tempfile.TemporaryDirectory(prefix="porosense-bench-record-") as tmp:
        for seed in seeds:
            scene = render.render(Path(tmp) / f"scene_{seed}.avi", seed=seed)
            per_seed.append(measure(scene))
    worst = {
        "curvature_rms_pct_of_max": max(r["curvature_rms_pct_of_max"] for r in per_seed),
        "dz_rms_mm": max(r["dz_rms_mm"] for r in per_seed),
        "sync_offset_frames_max": max(r["sync_offset_frames_max"] for r in per_seed),
        "tracking_fps": min(r["tracking_fps"] for r in per_seed),
        "tracking_fps_cpu": min(r["tracking_fps_cpu"] for r in per_seed),
    }
    summary = [
        f"rendered videos: {len(per_seed)} seeds, 640x480 at 30 fps, {per_seed[0]['n_frames']} frames each",
        f"curvature RMS: {worst['curvature_rms_pct_of_max']:.2f} % of max (worst seed; bound 3 %)",
        f"dz RMS: {worst['dz_rms_mm']:.3f} mm (worst seed; bound 0.3 mm)",
        f"sync offset: {worst['sync_offset_frames_max']:.3f} frames at 30 fps (worst frame, worst seed; bound 1)",
        f"tracking speed at 640x480 (slowest seed; real time is 30): {worst['tracking_fps']:.0f} frames/s "
        f"wall clock, {worst['tracking_fps_cpu']:.0f} frames per CPU second (decoding included)",
    ]
    return {"seeds": per_seed, "worst": worst, "summary": summary}
