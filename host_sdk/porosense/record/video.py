"""Frames from a video file or a camera, with one-line errors for what users get wrong."""

from __future__ import annotations

from pathlib import Path

import cv2

from porosense.errors import DeviceError, InputError


def _quiet() -> None:
    """Keep OpenCV's own warnings (one per back-end tried) off stderr: ours say it in one line."""
    try:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    except AttributeError:  # builds without the logging utilities
        pass


def open_video(path) -> tuple[cv2.VideoCapture, float, int]:
    """Open a video file; returns the capture, its frame rate (Hz) and frame count."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"video {path} not found")
    _quiet()
    cap = cv2.VideoCapture(str(path))
    ok = cap.isOpened()
    if ok:
        ok, _ = cap.read()
        cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
    if not ok:
        cap.release()
        raise InputError(f"cannot read video {path}: not a video file OpenCV can decode")
    fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
    if not fps > 0:
        cap.release()
        raise InputError(f"video {path} does not state its frame rate")
    return cap, fps, int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)


def open_camera(index: int, width: int = 640, height: int = 480, fps: float = 30.0) -> cv2.VideoCapture:
    """Open camera ``index`` and ask for ``width`` x ``height`` at ``fps``."""
    _quiet()
    cap = cv2.VideoCapture(int(index))
    ok = cap.isOpened()
    if ok:
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        cap.set(cv2.CAP_PROP_FPS, fps)
        ok, _ = cap.read()
    if not ok:
        cap.release()
        raise DeviceError(f"no camera at index {index} (or it gives no frames)")
    return cap
