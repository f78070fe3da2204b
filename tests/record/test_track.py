"""Tracking rendered video back: curvature, stroke and clock against the simulator's truth.

Bounds are set from `porosense bench record --size full` (5 seeds, worst case) with a margin;
the measured figures are in the docstrings and docs/camera.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from porosense.errors import InputError
from porosense.record.layout import Layout
from porosense.record.sync import fit_clock
from porosense.record.tracker import track_video
from porosense.record.truth import add_truth

# Measured worst cases over seeds 0-4 (bench full): see test docstrings; bounds add margin.
CURVATURE_RMS_PCT_BOUND = 1.5  # % of the maximum curvature (measured worst 0.58)
DZ_RMS_MM_BOUND = 0.15  # mm (measured worst 0.054)
SYNC_OFFSET_FRAMES_BOUND = 0.6  # frames at 30 fps, worst frame (measured worst 0.34)


# One worker runs the module, with test_record_cli.py: the tracked video is a module fixture and the
# rendered scene a session fixture that another worker would make again.
pytestmark = pytest.mark.xdist_group("record-scene")


@pytest.fixture(scope="module")
def tracked(scene):
    layout = Layout(**scene.layout)
    track = track_video(scene.video, layout)
    clock = fit_clock(track.t_cam, track.indicator, scene.board["t_dev_us"], track.fps)
    assert clock is not None, "no sync blinks found"
    rec = add_truth(scene.board, track, clock, marker_length_mm=layout.marker_length_mm)
    return scene, track, clock, rec


def test_curvature_against_truth(tracked):
    scene, _, _, rec = tracked
    ok = rec["camera_ok"] > 0
    err = rec["curvature"][ok] - scene.truth_curvature[ok]
    rms_pct = 100 * np.sqrt(np.mean(err**2)) / np.abs(scene.truth_curvature).max()
    print(f"curvature RMS {rms_pct:.3f} % of max {np.abs(scene.truth_curvature).max():.2f} 1/m")
    assert rms_pct <= CURVATURE_RMS_PCT_BOUND


def test_dz_and_strain_against_truth(tracked):
    scene, _, _, rec = tracked
    ok = rec["camera_ok"] > 0
    err = rec["dz"][ok] - scene.truth_dz[ok]
    rms = float(np.sqrt(np.mean(err**2)))
    print(f"dz RMS {rms:.4f} mm (max dz {scene.truth_dz.max():.2f} mm)")
    assert rms <= DZ_RMS_MM_BOUND
    np.testing.assert_allclose(rec["strain_0"][ok], rec["dz"][ok] / 50.0 * 100.0)


def test_sync_offset_within_bound(tracked):
    scene, track, clock, _ = tracked
    err_frames = np.abs(clock.to_dev(track.t_cam) - scene.true_dev_time(track.t_cam)) * scene.fps
    print(f"{clock}; worst frame offset {err_frames.max():.3f} frames")
    assert clock.method == "blinks"
    assert err_frames.max() <= SYNC_OFFSET_FRAMES_BOUND


def test_occluded_frames_are_flagged_not_filled(tracked):
    """Every frame with a hand over an actuator is flagged for that actuator (NaN), or the
    detection there still agrees with the truth; flagged samples carry camera_ok = 0."""
    scene, track, _, rec = tracked
    assert scene.occluded, "the renderer drew no occlusion"
    bad = ~track.ok_stripes | ~track.ok_marker
    assert np.all(np.isnan(track.curvature[~track.ok_stripes]))
    assert np.all(np.isnan(track.dz_mm[~track.ok_marker]))
    assert bad.sum() >= 1
    # Flags only where something was in the way (or next to it: motion blur of the hand).
    near = np.zeros(track.n_frames, bool)
    for k in scene.occluded:
        near[max(k - 1, 0) : k + 2] = True
    assert not np.any(bad & ~near), f"frames flagged without an occlusion: {np.flatnonzero(bad & ~near)}"
    assert np.all(np.isnan(rec["curvature"][rec["camera_ok"] == 0]) | np.isnan(rec["dz"][rec["camera_ok"] == 0]))


def test_too_many_failed_frames_is_an_error_naming_ranges(scene):
    layout = Layout(**{**scene.layout, "max_failed_fraction": 0.0})
    with pytest.raises(InputError, match=r"not found in \d+ of \d+ frames .*: frames \d+"):
        track_video(scene.video, layout)


def test_no_marker_is_an_error(scene):
    """A marker region over the bare wall holds no marker."""
    layout = Layout(**{**scene.layout, "stripes": None, "marker": [600, 300, 30, 30]})
    with pytest.raises(InputError, match="no marker found"):
        track_video(scene.video, layout)


def test_video_shorter_than_recording_is_an_error(tracked):
    scene, track, clock, _ = tracked
    from porosense.data import Recording

    t = np.arange(int(60 * 50)) / 50.0  # a 60 s recording against a ~32 s video
    board = Recording(t, {"t_dev_us": t * 1e6})
    with pytest.raises(InputError, match="the video is .* s too short"):
        add_truth(board, track, clock)


def test_region_outside_the_frame_is_an_error(scene):
    layout = Layout(**{**scene.layout, "marker": [630, 470, 40, 40]})
    with pytest.raises(InputError, match="lies outside the 640x480 frames"):
        track_video(scene.video, layout)
