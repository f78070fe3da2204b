"""Live capture: frames from a camera written to a video file with host timestamps, in a
background thread while the board runs its schedule (nothing is dropped to keep up: frames
are written as they come, tracking happens afterwards on the saved file).
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import cv2


class Capture:
    """Record camera ``cap`` to ``path`` (MJPEG AVI) with host times (s, time.monotonic)."""

    def __init__(self, cap: cv2.VideoCapture, path, fps: float = 30.0):
        self.cap, self.path, self.fps = cap, Path(path), float(fps)
        self.times: list[float] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera-capture", daemon=True)
        self._writer = None
        self.error: str | None = None

    def __enter__(self) -> Capture:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def _run(self) -> None:
        while not self._stop.is_set():
            ok, frame = self.cap.read()
            t = time.monotonic()
            if not ok:
                self.error = "the camera stopped giving frames"
                return
            if self._writer is None:
                size = (frame.shape[1], frame.shape[0])
                self._writer = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"MJPG"), self.fps, size)
            self._writer.write(frame)
            self.times.append(t)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)
        if self._writer is not None:
            self._writer.release()
        self.cap.release()
        self.path.with_suffix(".times.json").write_text(json.dumps({"host_time_s": self.times}), encoding="utf-8")
