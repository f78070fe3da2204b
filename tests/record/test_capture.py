"""Live capture: frames written as they come with host times; host-clock fallback alignment."""

from __future__ import annotations

import json
import time

import cv2
import numpy as np

from porosense.record.capture import Capture
from porosense.record.sync import host_clock


class _FakeCamera:
    """A camera giving ``n`` frames at ``fps`` (paced by sleeping), then nothing."""

    def __init__(self, n: int, fps: float):
        self.n, self.fps, self.k = n, fps, 0
        self.released = False

    def read(self):
        if self.k >= self.n:
            return False, None
        time.sleep(1.0 / self.fps)
        frame = np.full((48, 64, 3), (self.k * 7) % 256, np.uint8)
        self.k += 1
        return True, frame

    def release(self):
        self.released = True


def test_capture_keeps_every_frame_with_its_host_time(tmp_path):
    cam = _FakeCamera(40, 100.0)
    with Capture(cam, tmp_path / "live.avi", fps=100.0) as cap:
        deadline = time.monotonic() + 30
        while cam.k < cam.n and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.05)
    assert cam.released
    assert cap.error == "the camera stopped giving frames"
    times = json.loads((tmp_path / "live.times.json").read_text())["host_time_s"]
    assert len(times) == 40 and np.all(np.diff(times) > 0)
    video = cv2.VideoCapture(str(tmp_path / "live.avi"))
    n = 0
    while video.read()[0]:
        n += 1
    assert n == 40


def test_host_clock_maps_host_times_to_device_time():
    clock = host_clock(2.5, 150.0)
    np.testing.assert_allclose(clock.to_dev([2.5, 3.5]), [0.0, 1.0])
    assert clock.method == "host" and clock.expected_error_ms == 150.0
