"""``porosense record``: an experiment on a board with a camera's ground truth."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from porosense.cli._args import add_deprecated
from porosense.cli._data import add_json_options, emit_json, output_file
from porosense.errors import InputError

#: Host-timestamp alignment error with a live camera: a webcam's capture-to-delivery latency
#: (typically 30-150 ms) plus a sample period and the serial link's delivery jitter.
HOST_CLOCK_ERROR_MS = 150.0
#: Largest disagreement (relative) between a video file's stated frame rate and the board's clock
#: that the clock fit may still absorb: a recording longer than the video by more than this cannot
#: be covered, and is refused before the video is tracked (tracking reads every frame).
MAX_CLOCK_DISAGREEMENT = 0.05


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "record",
        help="run an experiment on a board while a camera measures the truth (curvature, dz, strain)",
        description=(
            "Run an experiment schedule on a board (serial URL of a real board, the simboard or the emulator) "
            "and take the ground truth from video: live from a camera (--camera N, saved beside the recording) "
            "or a video file filmed at the same time (--video FILE); --board-recording reprocesses an earlier "
            "board recording instead of running one. The tracker fits a circle to the bending actuator's "
            "stripes (curvature, 1/m) and follows the contractor's marker (dz, mm; strain % with "
            "marker_length_mm in the layout), in pixels scaled by a reference length or a checkerboard "
            "calibration. The board's sync indicator (D11) places the frames on its clock (offset and "
            "drift); without it the host clocks are used, with a warning. Writes one recording (CSV + JSON) "
            "with the board's samples and the truth resampled at the sample times. See docs/camera.md."
        ),
        epilog=(
            "example: porosense record --port /dev/ttyACM0 --camera 0 --layout layout.json "
            "--experiment step_60 --out runs/bending_step60.csv"
        ),
    )
    board = p.add_mutually_exclusive_group()
    board.add_argument("--port", metavar="URL", help="the board: serial port or pyserial URL")
    board.add_argument(
        "--board-recording",
        metavar="CSV",
        help="an earlier board recording (with t_dev_us) instead of running the schedule",
    )
    cam = p.add_mutually_exclusive_group()
    cam.add_argument("--camera", type=int, metavar="N", help="OpenCV camera index (live capture)")
    cam.add_argument("--video", metavar="FILE", help="a video filmed during the board's run")
    p.add_argument("--layout", metavar="JSON", help="regions and scale (docs/camera.md)")
    p.add_argument("--calibration", metavar="JSON", help="checkerboard calibration (replaces the reference)")
    p.add_argument("--experiment", "-e", default="step_60", help="schedule name (default: step_60)")
    p.add_argument("--channels", type=int, default=1, choices=(1, 2, 3), help="pressure channels (default 1)")
    p.add_argument("--rate", type=int, default=50, help="sample rate in Hz (default 50)")
    p.add_argument(
        "--video-start",
        type=float,
        default=0.0,
        metavar="S",
        help="without sync blinks: seconds into --video at which the stream started (default 0)",
    )
    p.add_argument("--preview", metavar="AVI", help="write a copy of the video with the detections drawn")
    p.add_argument("--out", required=True, metavar="CSV", help="the recording to write (CSV + JSON)")
    p.add_argument("--force", action="store_true", help="replace an existing --out (and its _board/_frames files)")
    cal = p.add_argument_group("camera calibration (instead of a recording)")
    cal.add_argument(
        "--calibrate",
        nargs="+",
        metavar="IMAGE",
        help="checkerboard images; the last one with the board in the actuator's plane. "
        "Writes the calibration JSON to --out",
    )
    cal.add_argument("--pattern", default="9x6", metavar="CxR", help="inner corners (default 9x6)")
    cal.add_argument("--square-mm", type=float, default=None, help="checkerboard square size in mm")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_deprecated(p, "--no-progress", "--quiet", "quiet", nargs=0)
    add_json_options(p, "the result")
    p.set_defaults(func=run)
    return p


def _warn(text: str) -> None:
    print(f"porosense record: warning: {text}", file=sys.stderr)


def _refuse_a_video_too_short(video_path: Path, board) -> None:
    """Refuse a video file whose length (its frame count over its frame rate) falls short of the
    board recording's device-time span by more than any clock disagreement could explain
    (MAX_CLOCK_DISAGREEMENT, plus two frames). The exact check, on the fitted clock, follows the
    tracking; this one costs no frame. A file that states no frame count is left to that check."""
    from porosense.record.video import open_video

    cap, fps, n_frames = open_video(video_path)
    cap.release()
    if n_frames <= 0 or "t_dev_us" not in board or len(board) < 2:
        return
    t_us = board["t_dev_us"]
    span_s = float(t_us[-1] - t_us[0]) * 1e-6
    video_s = n_frames / fps
    short = span_s - video_s * (1.0 + MAX_CLOCK_DISAGREEMENT) - 2.0 / fps
    if short > 0:
        raise InputError(
            f"the video {video_path} lasts {video_s:.2f} s but the board recording spans {span_s:.2f} s: "
            f"the video is at least {short:.2f} s too short"
        )


def run(args) -> int:
    from porosense.record.calibration import Calibration
    from porosense.record.layout import Layout
    from porosense.record.sync import ClockFit, fit_clock, host_clock
    from porosense.record.tracker import track_video
    from porosense.record.truth import add_truth, frame_table
    from porosense.record.video import open_camera, open_video

    if args.calibrate:
        return _calibrate(args)
    for option, given in (
        ("--port or --board-recording", args.port or args.board_recording),
        ("--camera or --video", args.camera is not None or args.video),
        ("--layout", args.layout),
    ):
        if not given:
            raise InputError(f"{option} is required to record")
    if args.camera is not None and not args.port:
        raise InputError("--camera films a board run: give --port (use --video with --board-recording)")
    layout = Layout.load(args.layout)
    calibration = Calibration.load(args.calibration) if args.calibration else None
    out = Path(args.out)
    _refuse_to_replace(out, args)
    progress = not args.quiet
    # Check the inputs before a long experiment runs.
    if args.video:
        open_video(args.video)[0].release()
    camera = open_camera(args.camera) if args.camera is not None else None

    host_times = None
    t_host_start = None
    if args.board_recording:
        from porosense.data import Recording

        board = Recording.from_csv(args.board_recording)
        if "t_dev_us" not in board:
            raise InputError(f"{args.board_recording}: no t_dev_us column (device time) to synchronise with")
    else:
        video_path = Path(args.video) if args.video else out.with_suffix(".avi")
        board, host_times, t_host_start = _run_board(args, camera, video_path, progress)
        # The board's samples are kept whatever happens to the video.
        saved = board.to_csv(out.with_name(out.stem + "_board.csv"))
        if not args.json:
            print(f"board samples saved to {saved}")
    video_path = Path(args.video) if args.video else out.with_suffix(".avi")
    if args.video and camera is None:  # a camera's file is timed by the host's clock, not its stated rate
        _refuse_a_video_too_short(video_path, board)
    timestamps = None
    if host_times is not None:
        timestamps = [t - host_times[0] for t in host_times]
    track = track_video(video_path, layout, calibration, timestamps=timestamps, progress=progress, preview=args.preview)
    clock = None
    if layout.indicator is not None:
        clock = fit_clock(track.t_cam, track.indicator, board["t_dev_us"], track.fps)
    if clock is None:
        why = "no indicator region in the layout" if layout.indicator is None else "no sync blinks seen"
        if host_times is not None:
            clock = host_clock(t_host_start - host_times[0], HOST_CLOCK_ERROR_MS)
            _warn(
                f"{why}: frames aligned by host timestamps; expected error up to "
                f"{HOST_CLOCK_ERROR_MS:.0f} ms ({HOST_CLOCK_ERROR_MS * track.fps / 1000:.1f} frames)"
            )
        else:
            clock = ClockFit(-args.video_start, 0.0, float("nan"), 0, "video start", 1000.0)
            _warn(
                f"{why}: the stream is taken to start {args.video_start:g} s into the video; expected "
                f"error is how well that start is known (typically 0.2-1 s by hand, 6-30 frames)"
            )
    rec = add_truth(board, track, clock, marker_length_mm=layout.marker_length_mm)
    rec.meta["camera"]["video"] = str(video_path)
    path = rec.to_csv(out)
    frames = frame_table(track, clock).to_csv(out.with_name(out.stem + "_frames.csv"))
    missing = rec.meta["camera"]["samples_without_truth"]
    result = {
        "recording": str(path),
        "frames": str(frames),
        "samples": len(rec),
        "clock": clock.to_dict(),
        "track": track.to_dict(),
        "samples_without_truth": missing,
    }
    emit_json(result, args)
    if not args.json:
        print(f"{track!r}")
        print(str(clock))
        if missing:
            print(
                f"{missing} samples without truth (NaN, camera_ok = 0): samples "
                f"{rec.meta['camera']['sample_ranges_without_truth']}"
            )
        print(
            f"wrote {path} ({len(rec)} samples, truth: {', '.join(rec.meta['camera']['truth_columns'])}) "
            f"and the per-frame values to {frames}"
        )
    return 0


def _calibrate(args) -> int:
    import cv2

    from porosense.record.calibration import calibrate

    output_file(args.out, "--out", force=args.force)

    try:
        cols, rows = (int(v) for v in args.pattern.lower().split("x"))
    except ValueError:
        raise InputError(f"--pattern {args.pattern}: expected inner corners as CxR, e.g. 9x6") from None
    if not (args.square_mm and args.square_mm > 0):
        raise InputError("--calibrate needs --square-mm (the checkerboard's square size in mm)")
    images = []
    for name in args.calibrate:
        img = cv2.imread(name, cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise InputError(f"cannot read image {name}")
        images.append(img)
    cal = calibrate(images, (cols, rows), args.square_mm)
    path = cal.save(args.out)
    emit_json({"calibration": str(path), "rms_px": cal.rms_px}, args)
    if not args.json:
        print(f"calibrated from {len(images)} images: reprojection rms {cal.rms_px:.3f} px; wrote {path}")
    return 0


def _refuse_to_replace(out: Path, args) -> None:
    """A recording already on disk is kept unless --force says otherwise."""
    written = [out, out.with_name(out.stem + "_board.csv"), out.with_name(out.stem + "_frames.csv")]
    if args.port and not args.video:
        written.append(out.with_suffix(".avi"))
    for path in written:
        output_file(path, "--out", force=args.force)


def _run_board(args, camera, video_path: Path, progress: bool):
    """Run the schedule on the board, capturing the camera when live; returns the board
    recording, the frames' host times (or None) and the host time of the stream start."""
    from porosense.device import Device
    from porosense.experiment import run_schedule
    from porosense.record.capture import Capture
    from porosense.sim.schedules import schedule

    sched = schedule(args.experiment)
    # The samples go to disk as they arrive: a run killed midway leaves them in _board.csv.
    log = Path(args.out).with_name(Path(args.out).stem + "_board.csv")
    opts = dict(rate_hz=args.rate, n_channels=args.channels, progress=progress, log_path=log)
    with Device.open(args.port) as dev:
        if camera is None:
            t0 = time.monotonic()
            return run_schedule(dev, sched, **opts), None, t0
        with Capture(camera, video_path) as cap:
            time.sleep(1.0)  # the video starts before the stream: the start code is in view
            t0 = time.monotonic() + 1.0 / args.rate  # host time of the first sample, roughly
            board = run_schedule(dev, sched, **opts)
            time.sleep(0.5)
        if cap.error:
            _warn(cap.error)
        return board, cap.times, t0
