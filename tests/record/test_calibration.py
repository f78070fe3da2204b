"""Checkerboard calibration on synthetic views from a known camera with lens distortion."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from porosense.errors import InputError
from porosense.record.calibration import Calibration, calibrate

PATTERN, SQUARE_MM = (9, 6), 12.0
W, H = 640, 480


def _camera(rng):
    f = rng.uniform(550, 750)
    k = np.array([[f, 0, W / 2 + rng.uniform(-15, 15)], [0, f, H / 2 + rng.uniform(-15, 15)], [0, 0, 1.0]])
    dist = np.array([rng.uniform(-0.3, -0.1), rng.uniform(0.02, 0.12), 0.0, 0.0, 0.0])
    return k, dist


def _view(k, dist, rvec, tvec):
    """An 8-bit image of the board (10 x 7 squares, white border) seen through the camera."""
    img = np.full((H, W), 235, np.uint8)
    cols, rows = PATTERN[0] + 1, PATTERN[1] + 1
    margin = SQUARE_MM
    border = np.array(
        [
            [-margin, -margin],
            [cols * SQUARE_MM - SQUARE_MM + margin + SQUARE_MM, -margin],
            [cols * SQUARE_MM + margin, rows * SQUARE_MM + margin],
            [-margin, rows * SQUARE_MM + margin],
        ]
    )
    # The board's squares start at -1 square so the inner corners are at multiples of SQUARE_MM.
    off = -SQUARE_MM
    img[:] = 90  # the scene behind the board
    cv2.fillPoly(img, [_project(border + off, k, dist, rvec, tvec)], 235, cv2.LINE_AA, shift=4)
    for i in range(cols):
        for j in range(rows):
            if (i + j) % 2 == 0:
                sq = np.array([[i, j], [i + 1, j], [i + 1, j + 1], [i, j + 1]], float) * SQUARE_MM + off
                cv2.fillPoly(img, [_project(sq, k, dist, rvec, tvec)], 20, cv2.LINE_AA, shift=4)
    return cv2.GaussianBlur(img, (0, 0), 0.7)


def _project(poly_mm, k, dist, rvec, tvec, per_edge: int = 8):
    """Polygon in plane mm -> image polygon (fixed point, shift 4), edges bent by distortion."""
    pts = []
    for a, b in zip(poly_mm, np.roll(poly_mm, -1, axis=0)):
        for s in np.linspace(0, 1, per_edge, endpoint=False):
            pts.append(a + s * (b - a))
    obj = np.c_[np.array(pts), np.zeros(len(pts))]
    img, _ = cv2.projectPoints(obj, rvec, tvec, k, dist)
    return np.round(img.reshape(-1, 2) * 16).astype(np.int32)


def test_calibration_recovers_plane_millimetres(tmp_path):
    """Eight tilted views plus one frontal (the actuator plane). Measured: reprojection rms
    0.25 px, plane points mapped back to mm with 0.018 mm rms error (12 mm squares span ~25 px).
    Bounds: 0.5 px and 0.1 mm."""
    rng = np.random.default_rng(5)
    k, dist = _camera(rng)
    views = []
    for _ in range(8):
        rvec = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.2, 0.2)])
        tvec = np.array([rng.uniform(-60, -30), rng.uniform(-40, -20), rng.uniform(280, 380)])
        views.append(_view(k, dist, rvec, tvec))
    plane_r, plane_t = np.array([0.05, -0.04, 0.02]), np.array([-55.0, -35.0, 330.0])
    views.append(_view(k, dist, plane_r, plane_t))
    cal = calibrate(views, PATTERN, SQUARE_MM)
    cal = Calibration.load(cal.save(tmp_path / "cal.json"))
    # Random points of the plane, seen through the true camera, mapped back to mm.
    pts_mm = np.c_[rng.uniform(0, 8 * SQUARE_MM, 200), rng.uniform(0, 5 * SQUARE_MM, 200)]
    px, _ = cv2.projectPoints(np.c_[pts_mm, np.zeros(200)], plane_r, plane_t, k, dist)
    back = cal.to_mm(px.reshape(-1, 2))
    # The homography fixes the plane's origin at the first inner corner: compare shapes.
    err = back - pts_mm
    err -= err.mean(axis=0)
    rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
    print(f"reprojection rms {cal.rms_px:.3f} px; plane mm rms {rms:.4f} mm")
    assert cal.rms_px < 0.5
    assert rms < 0.1


def test_calibration_without_the_board_is_an_error():
    blank = [np.full((H, W), 128, np.uint8)] * 4
    with pytest.raises(InputError, match="checkerboard 9x6 not found"):
        calibrate(blank, PATTERN, SQUARE_MM)


def test_calibrate_command(tmp_path, capfd):
    from porosense.cli import main

    rng = np.random.default_rng(9)
    k, dist = _camera(rng)
    names = []
    for i in range(5):
        rvec = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), 0.0])
        tvec = np.array([-50.0, -30.0, rng.uniform(300, 360)])
        names.append(str(tmp_path / f"v{i}.png"))
        cv2.imwrite(names[-1], _view(k, dist, rvec, tvec))
    code = main(
        [
            "record",
            "--calibrate",
            *names,
            "--pattern",
            "9x6",
            "--square-mm",
            str(SQUARE_MM),
            "--out",
            str(tmp_path / "cal.json"),
        ]
    )
    out, err = capfd.readouterr()
    assert code == 0, err
    assert Calibration.load(tmp_path / "cal.json").rms_px < 0.5
    code = main(["record", "--calibrate", *names, "--out", str(tmp_path / "c2.json")])
    _, err = capfd.readouterr()
    assert code == 2 and "--square-mm" in err
