"""``porosense record``: a recording from a board recording plus video; one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import Recording

# One worker runs the module: every test reads the rendered scene, a session fixture that each
# worker renders for itself.
pytestmark = pytest.mark.xdist_group("record-scene")  # with test_track.py


def _run(capfd, *argv):
    code = main(["record", *argv])
    out, err = capfd.readouterr()
    return code, out, err


def _one_line_error(err: str, pattern: str):
    lines = [ln for ln in err.strip().splitlines() if ln]
    assert len(lines) == 1, err
    assert pattern in lines[0], lines[0]
    assert "Traceback" not in err


def test_record_from_board_recording_and_video(scene, tmp_path, capfd):
    base = scene.video.parent
    out = tmp_path / "rec.csv"
    code, stdout, err = _run(
        capfd,
        "--board-recording",
        str(base / "board.csv"),
        "--video",
        str(scene.video),
        "--layout",
        str(base / "layout.json"),
        "--out",
        str(out),
        "--quiet",
        "--json",
        "--preview",
        str(tmp_path / "preview.avi"),
    )
    assert code == 0, err
    result = json.loads(stdout)
    assert result["clock"]["method"] == "blinks"
    rec = Recording.from_csv(out)
    for name in ("curvature", "dz", "strain_0", "t_cam", "camera_ok", "t_dev_us"):
        assert name in rec
    ok = rec["camera_ok"] > 0
    assert ok.mean() > 0.9
    err_k = rec["curvature"][ok] - scene.truth_curvature[ok]
    assert 100 * np.sqrt(np.mean(err_k**2)) / scene.truth_curvature.max() < 3.0
    assert rec.meta["camera"]["clock"]["method"] == "blinks"
    import cv2

    preview = cv2.VideoCapture(str(tmp_path / "preview.avi"))
    assert int(preview.get(cv2.CAP_PROP_FRAME_COUNT)) == scene.n_frames
    frames = Recording.from_csv(result["frames"])
    assert len(frames) == scene.n_frames
    assert np.all(np.isnan(frames["dz"][frames["marker_ok"] == 0]))


def test_without_indicator_warns_with_expected_error(scene, tmp_path, capfd):
    base = scene.video.parent
    layout = dict(scene.layout)
    layout.pop("indicator")
    (tmp_path / "layout.json").write_text(json.dumps(layout))
    code, _, err = _run(
        capfd,
        "--board-recording",
        str(base / "board.csv"),
        "--video",
        str(scene.video),
        "--layout",
        str(tmp_path / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
        "--quiet",
        "--video-start",
        f"{scene.lead_s:.1f}",
    )
    assert code == 0, err
    assert "warning: no indicator region" in err and "expected error" in err


def test_missing_camera(scene, tmp_path, capfd):
    """The camera is checked before the board is touched (the port here does not exist)."""
    base = scene.video.parent
    code, _, err = _run(
        capfd,
        "--port",
        "socket://127.0.0.1:9",
        "--camera",
        "97",
        "--layout",
        str(base / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
    )
    assert code == 3
    _one_line_error(err, "no camera at index 97")
    code, _, err = _run(
        capfd,
        "--board-recording",
        str(base / "board.csv"),
        "--camera",
        "97",
        "--layout",
        str(base / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
    )
    assert code == 2
    _one_line_error(err, "--camera films a board run")


def test_unreadable_video(scene, tmp_path, capfd):
    bad = tmp_path / "broken.avi"
    bad.write_bytes(b"this is not a video\n" * 100)
    base = scene.video.parent
    code, _, err = _run(
        capfd,
        "--board-recording",
        str(base / "board.csv"),
        "--video",
        str(bad),
        "--layout",
        str(base / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
    )
    assert code == 2
    _one_line_error(err, "cannot read video")


def test_no_marker_found(scene, tmp_path, capfd):
    base = scene.video.parent
    layout = {**scene.layout, "stripes": None, "marker": [600, 300, 30, 30]}
    (tmp_path / "layout.json").write_text(json.dumps(layout))
    code, _, err = _run(
        capfd,
        "--board-recording",
        str(base / "board.csv"),
        "--video",
        str(scene.video),
        "--layout",
        str(tmp_path / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
        "--quiet",
    )
    assert code == 2
    _one_line_error(err, "no marker found")


def test_video_shorter_than_recording(scene, tmp_path, capfd):
    base = scene.video.parent
    t = np.arange(60 * 50) / 50.0  # 60 s of board samples against a ~32 s video
    t_us = scene.board["t_dev_us"][0] + t * 1e6
    Recording(t, {"t_dev_us": t_us}).to_csv(tmp_path / "long.csv")
    code, _, err = _run(
        capfd,
        "--board-recording",
        str(tmp_path / "long.csv"),
        "--video",
        str(scene.video),
        "--layout",
        str(base / "layout.json"),
        "--out",
        str(tmp_path / "r.csv"),
        "--quiet",
    )
    assert code == 2
    _one_line_error(err, "s too short")


def test_board_run_on_the_emulator_with_a_too_short_video(scene, tmp_path, capfd):
    """--port runs the schedule on a board (here the emulator, 65 s of step_10) and then finds
    the ~32 s video does not cover it: one line, and the board recording is not lost."""
    from porosense.emulator import Emulator

    base = scene.video.parent
    with Emulator("contractor", seed=2) as emu:
        code = main(
            [
                "record",
                "--port",
                emu.url,
                "--video",
                str(scene.video),
                "--layout",
                str(base / "layout.json"),
                "--experiment",
                "step_10",
                "--out",
                str(tmp_path / "r.csv"),
                "--quiet",
            ]
        )
    _, err = capfd.readouterr()
    assert code == 2
    _one_line_error(err, "s too short")
    assert Recording.from_csv(tmp_path / "r_board.csv").duration > 60.0


def test_sigkill_during_the_board_run_leaves_the_samples_so_far(scene, tmp_path):
    """The board's samples reach <out>_board.csv as they arrive (flushed every second): a record
    killed midway keeps every sample up to a flush before the kill, whole rows in time order."""
    import csv
    import os
    import signal
    import subprocess
    import sys
    import time

    from porosense.emulator import Emulator

    base = scene.video.parent
    log = tmp_path / "r_board.csv"

    def rows() -> list[dict]:
        with open(log, newline="") as fh:
            return list(csv.DictReader(fh))

    with Emulator("contractor", seed=3, realtime=True) as emu:  # a run that lasts until the kill
        args = ["record", "--port", emu.url, "--video", str(scene.video), "--layout", str(base / "layout.json")]
        args += ["--experiment", "staircase", "--out", str(tmp_path / "r.csv"), "--quiet"]
        proc = subprocess.Popen(
            [sys.executable, "-m", "porosense", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        try:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and (not log.exists() or len(rows()) < 50):
                assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
                time.sleep(0.2)
            time.sleep(2.0)
            seen = len(rows())  # on disk more than a flush period before the kill
            time.sleep(1.2)
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
    kept = rows()
    t = [int(r["t_dev_us"]) for r in kept]
    print(f"SIGKILL during record: {len(kept)} samples readable ({(t[-1] - t[0]) / 1e6:.1f} s of device time)")
    assert len(kept) >= seen > 50
    assert all(b > a for a, b in zip(t, t[1:]))
    assert set(kept[0]) == {"t_dev_us", "adc_0", "dR_0", "status"}


def test_an_existing_recording_is_replaced_only_with_force(scene, tmp_path, capfd):
    """Before anything runs, a recording already at --out (or its _board/_frames files) is kept."""
    base = scene.video.parent
    (tmp_path / "r_board.csv").write_text("t\n0\n")
    args = ["record", "--board-recording", str(base / "board.csv"), "--video", str(scene.video)]
    args += ["--layout", str(base / "layout.json"), "--out", str(tmp_path / "r.csv"), "--quiet"]
    code = main(args)
    _, err = capfd.readouterr()
    assert code == 2
    _one_line_error(err, "--force replaces it")
    assert (tmp_path / "r_board.csv").read_text() == "t\n0\n"


def test_a_video_is_refused_unread_only_beyond_what_the_clock_fit_could_absorb(scene):
    """The check before tracking refuses a recording longer than the video by more than
    MAX_CLOCK_DISAGREEMENT (5 %) plus two frames, and leaves anything closer to the exact check
    on the fitted clock (a camera whose stated rate is off by a few percent still records)."""
    from porosense.cli.record import MAX_CLOCK_DISAGREEMENT, _refuse_a_video_too_short
    from porosense.errors import InputError
    from porosense.record.video import open_video

    cap, fps, n_frames = open_video(scene.video)
    cap.release()
    video_s = n_frames / fps

    def board(span_s: float) -> Recording:
        t = np.linspace(0.0, span_s, 50)
        return Recording(t, {"t_dev_us": 1e6 + t * 1e6})

    _refuse_a_video_too_short(scene.video, board(video_s * (1.0 + 0.9 * MAX_CLOCK_DISAGREEMENT)))
    with pytest.raises(InputError, match="s too short"):
        _refuse_a_video_too_short(scene.video, board(video_s * (1.0 + MAX_CLOCK_DISAGREEMENT) + 3.0 / fps))
