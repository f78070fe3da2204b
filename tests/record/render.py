"""Renderer of test videos: the bending actuator's striped sleeve, the contractor's marker and
the board's sync indicator, drawn from the simulator's true motion and filmed by an imperfect
camera (roll, uneven lighting, blur, sensor noise, occluding hands, MJPEG encoding).

Written independently of porosense.record: it knows the scene's geometry and the indicator's
documented on-intervals, never the tracker's code. Every nuisance parameter is drawn from a
wide range by the seed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from porosense.data import Recording
from porosense.sim import make_plant
from porosense.sim.schedules import Schedule

W, H = 640, 480
SUB = 16  # fixed-point factor of cv2's sub-pixel drawing (shift=4)
BOARD_RATE_HZ = 50


def short_schedule() -> Schedule:
    """28 s on channel 0: rest, -60 kPa, rest, -20 kPa, rest (shorter than the paper's)."""
    ch = ((0.0, 0.0), (2.0, -60.0), (10.0, 0.0), (16.0, -20.0), (22.0, 0.0))
    return Schedule("camera_test", 28.0, (ch, ch, ch), "camera test: -60 and -20 kPa steps")


def indicator_on_fraction(t0, t1) -> np.ndarray:
    """Fraction of [t0, t1] (device s from the stream start) the indicator is on.

    The documented pattern: on [0, 0.4) and [0.6, 0.8) s, then [4k, 4k + 0.2) s for k >= 1.
    """
    t0, t1 = np.asarray(t0, float), np.asarray(t1, float)
    on = np.zeros_like(t0)
    k_max = int(max(np.max(t1), 0) // 4.0) + 1
    intervals = [(0.0, 0.4), (0.6, 0.8)] + [(4.0 * k, 4.0 * k + 0.2) for k in range(1, k_max + 1)]
    for a, b in intervals:
        on += np.clip(np.minimum(t1, b) - np.maximum(t0, a), 0.0, None)
    return on / (t1 - t0)


@dataclass
class Scene:
    """What the renderer drew and how: the truth and the camera's parameters."""

    video: Path
    board: Recording  # board samples: t, t_dev_us (device clock)
    truth_curvature: np.ndarray  # 1/m at the board samples
    truth_dz: np.ndarray  # mm at the board samples
    fps: float
    lead_s: float  # video start before the stream start (device s)
    drift_ppm: float  # camera clock rate error
    n_frames: int
    layout: dict
    occluded: list = field(default_factory=list)  # frame indices with a hand in view
    params: dict = field(default_factory=dict)

    def true_dev_time(self, t_cam) -> np.ndarray:
        """Device time (s from the stream start) of camera time ``t_cam`` (s from frame 0)."""
        return -self.lead_s + (1.0 + self.drift_ppm * 1e-6) * np.asarray(t_cam, float)


def _truth(schedule: Schedule, rate_hz: float, seed: int):
    """True curvature (1/m) and contractor stroke (mm) at rate_hz from the simulator."""
    t = schedule.times(rate_hz)
    sp, pump, valve = schedule.actuation(t)
    bend = make_plant("bending", seed=seed, noise=False).run(1.0 / rate_hz, sp, pump, valve)
    contr = make_plant("contractor", seed=seed, noise=False).run(1.0 / rate_hz, sp, pump, valve)
    length = make_plant("contractor").physics.sensors.contractor_length_mm
    # run() returns the state at the end of each step: time (k + 1) / rate.
    return t + 1.0 / rate_hz, np.asarray(bend["curvature"]), np.asarray(contr["strain_0"]) / 100.0 * length


def _poly(img, pts, colour):
    cv2.fillPoly(img, [np.round(np.asarray(pts) * SUB).astype(np.int32)], colour, cv2.LINE_AA, shift=4)


def _disc(img, c, r, colour):
    cv2.circle(img, tuple(int(round(v * SUB)) for v in c), int(round(r * SUB)), colour, -1, cv2.LINE_AA, shift=4)


def render(path, *, seed: int = 0, schedule: Schedule | None = None, fps: float = 30.0, occlusions: int = 3) -> Scene:
    """Render a video of ``schedule`` (default :func:`short_schedule`) to ``path`` (MJPEG AVI)."""
    rng = np.random.default_rng(seed)
    schedule = schedule or short_schedule()
    t_fine, kappa_fine, dz_fine = _truth(schedule, 200.0, seed)

    px_mm = rng.uniform(2.6, 3.4)  # camera scale, px per mm
    roll = np.radians(rng.uniform(-3.0, 3.0))  # camera roll
    drift_ppm = rng.uniform(-300.0, 300.0)
    lead_s = rng.uniform(0.5, 2.5)
    exposure = rng.uniform(0.3, 0.9) / fps  # exposure time, s
    blur = rng.uniform(0.6, 1.4)  # Gaussian blur sigma, px
    noise = rng.uniform(1.5, 5.0)  # sensor noise, grey levels rms
    light_dir = rng.uniform(0, 2 * np.pi)
    light_min = rng.uniform(0.55, 0.8)  # darkest corner's gain
    wall, body, ink = rng.uniform(150, 185), rng.uniform(205, 225), rng.uniform(20, 50)

    centre = np.array([W / 2, H / 2])
    rot = np.array([[np.cos(roll), -np.sin(roll)], [np.sin(roll), np.cos(roll)]])

    def cam(p_mm):  # scene mm (x right, y down, origin at the image centre) -> px
        return (np.asarray(p_mm, float) * px_mm) @ rot.T + centre

    # Bending actuator: clamped at the left, its midline an arc of length L bending downwards.
    L, width = 120.0, 15.0
    base = np.array([-95.0, -50.0])
    stripe_s = np.linspace(8.0, L - 8.0, 7)
    stripe_w = 5.0

    def arc(s, off, k):  # point at arc length s, offset off (mm) towards the centre of curvature
        k = k / 1000.0  # 1/m -> 1/mm
        if abs(k) < 1e-9:
            return np.stack([base[0] + s, base[1] + off + 0 * s], -1)
        th = s * k
        r = 1.0 / k
        return np.stack([base[0] + np.sin(th) * (r - off), base[1] + r - np.cos(th) * (r - off)], -1)

    # Contractor: hangs from a fixed top; its bottom cap (with the marker) rises by dz.
    c_top, c_len, c_wid, marker_r = np.array([75.0, -65.0]), 50.0, 25.0, 3.0
    # Reference: two dots 100 mm apart on a ruler strip.
    ref_a, ref_b, ref_r = np.array([-50.0, 62.0]), np.array([50.0, 62.0]), 2.5
    led = np.array([-90.0, 60.0])

    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    ramp = ((xx - W / 2) * np.cos(light_dir) + (yy - H / 2) * np.sin(light_dir)) / (W / 2)
    vign = ((xx - W / 2) ** 2 + (yy - H / 2) ** 2) / (W / 2) ** 2
    gain = 1.0 - (1.0 - light_min) * np.clip(0.5 * (ramp + 1.0) * 0.7 + 0.3 * vign, 0, 1)

    duration = schedule.duration_s + lead_s + rng.uniform(1.0, 2.0)
    n_frames = int(duration * fps)
    t_cam = np.arange(n_frames) / fps
    t_dev = -lead_s + (1.0 + drift_ppm * 1e-6) * t_cam
    kappa = np.interp(t_dev, t_fine, kappa_fine, left=0.0)
    dz = np.interp(t_dev, t_fine, dz_fine, left=0.0)
    led_on = indicator_on_fraction(t_dev - exposure / 2, t_dev + exposure / 2)

    occluded = {}
    for _ in range(occlusions):
        start = int(rng.integers(int(3 * fps), n_frames - 10))
        target = rng.choice(["bending", "contractor"])
        for k in range(start, start + int(rng.integers(2, 6))):
            occluded[k] = target

    path = Path(path)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (W, H))
    if not writer.isOpened():
        raise RuntimeError("cv2.VideoWriter cannot write MJPEG")
    s_fine = np.linspace(0.0, L, 60)
    for k in range(n_frames):
        img = np.full((H, W), wall, np.float32)
        # bending body and stripes
        edge_a, edge_b = arc(s_fine, -width / 2, kappa[k]), arc(s_fine, width / 2, kappa[k])
        _poly(img, cam(np.vstack([edge_a, edge_b[::-1]])), body)
        for s in stripe_s:
            ss = np.linspace(s - stripe_w / 2, s + stripe_w / 2, 4)
            a, b = arc(ss, -width / 2, kappa[k]), arc(ss, width / 2, kappa[k])
            _poly(img, cam(np.vstack([a, b[::-1]])), ink)
        # contractor body (top fixed) and marker on its bottom cap
        bottom = c_top[1] + c_len - dz[k]
        rect = [
            [c_top[0] - c_wid / 2, c_top[1]],
            [c_top[0] + c_wid / 2, c_top[1]],
            [c_top[0] + c_wid / 2, bottom],
            [c_top[0] - c_wid / 2, bottom],
        ]
        _poly(img, cam(rect), body)
        _disc(img, cam([c_top[0], bottom - 5.0]), marker_r * px_mm, ink)
        # reference ruler and its dots
        _poly(img, cam([[-60, 56], [60, 56], [60, 68], [-60, 68]]), body)
        _disc(img, cam(ref_a), ref_r * px_mm, ink)
        _disc(img, cam(ref_b), ref_r * px_mm, ink)
        # indicator LED: dark housing, light integrated over the exposure
        _disc(img, cam(led), 4.0 * px_mm, 40.0)
        _disc(img, cam(led), 2.0 * px_mm, 40.0 + 215.0 * led_on[k])
        if k in occluded:  # a hand passes in front of one actuator
            if occluded[k] == "bending":
                c = cam(arc(np.array([L * 0.6]), 0.0, kappa[k])[0])
            else:
                c = cam([c_top[0], bottom - 5.0])
            hand = c + rng.normal(0, 8, 2)
            cv2.ellipse(
                img,
                tuple(int(v) for v in hand),
                (int(30 * px_mm / 3), int(45 * px_mm / 3)),
                float(rng.uniform(0, 180)),
                0,
                360,
                float(rng.uniform(160, 200)),
                -1,
                cv2.LINE_AA,
            )
        img = cv2.GaussianBlur(img, (0, 0), blur) * gain
        img += rng.normal(0.0, noise, img.shape).astype(np.float32)
        frame = np.clip(img, 0, 255).astype(np.uint8)
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    writer.release()

    # Board side: samples every 20 ms of device time from an arbitrary clock value.
    t_board = schedule.times(BOARD_RATE_HZ)
    t0_us = int(rng.integers(0, 2**31))
    t_dev_us = t0_us + np.round(t_board * 1e6).astype(np.int64)
    board = Recording(
        t_board, {"t_dev_us": t_dev_us.astype(float)}, meta={"schedule": schedule.name}, units={"t_dev_us": "us"}
    )

    def box(points_mm, margin_mm):
        p = cam(points_mm)
        lo, hi = p.min(0) - margin_mm * px_mm, p.max(0) + margin_mm * px_mm
        lo, hi = np.maximum(lo, 0), np.minimum(hi, [W - 1, H - 1])
        return [int(lo[0]), int(lo[1]), int(hi[0] - lo[0]), int(hi[1] - lo[1])]

    arc_extent = np.vstack(
        [arc(s_fine, o, kk) for o in (-width / 2, width / 2) for kk in (0.0, float(kappa_fine.max()))]
    )
    layout = {
        "stripes": box(arc_extent, 6.0),
        "marker": box([[c_top[0] - c_wid / 2, c_top[1] + c_len * 0.4], [c_top[0] + c_wid / 2, c_top[1] + c_len]], 2.0),
        "indicator": box([led - 2.0, led + 2.0], 0.0),
        "reference": box([ref_a, ref_b], 4.0),
        "reference_mm": float(np.linalg.norm(ref_b - ref_a)),
        "feature_px": int(np.ceil(9.0 * px_mm)),
        "marker_length_mm": c_len,
    }
    params = {
        "px_per_mm": px_mm,
        "roll_deg": float(np.degrees(roll)),
        "exposure_s": exposure,
        "blur_px": blur,
        "noise": noise,
        "light_min": light_min,
    }
    return Scene(
        path,
        board,
        np.interp(t_board, t_fine, kappa_fine, left=0.0),
        np.interp(t_board, t_fine, dz_fine, left=0.0),
        fps,
        lead_s,
        drift_ppm,
        n_frames,
        layout,
        sorted(occluded),
        params,
    )
