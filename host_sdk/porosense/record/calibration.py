"""Checkerboard camera calibration: lens distortion removed, image points -> plane mm.

``calibrate`` runs ``cv2.calibrateCamera`` on views of a checkerboard; the last view must
show the board lying in the actuator's plane of motion, and its pose gives the homography
from undistorted pixels to millimetres in that plane. Saved as JSON (docs/camera.md).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from porosense.errors import InputError
from porosense.files import write_text


@dataclass
class Calibration:
    """Camera matrix K (px), distortion coefficients, reprojection rms (px), plane homography."""

    camera_matrix: np.ndarray
    distortion: np.ndarray
    rms_px: float
    plane_homography: np.ndarray  # undistorted px -> mm in the actuator plane
    image_size: tuple

    def undistort(self, points_px) -> np.ndarray:
        """Raw pixel points (N, 2) -> undistorted pixel points (same camera matrix)."""
        p = np.asarray(points_px, dtype=np.float64).reshape(-1, 1, 2)
        return cv2.undistortPoints(p, self.camera_matrix, self.distortion, P=self.camera_matrix).reshape(-1, 2)

    def to_mm(self, points_px) -> np.ndarray:
        """Raw pixel points (N, 2) -> mm in the actuator plane."""
        p = self.undistort(points_px).reshape(-1, 1, 2)
        return cv2.perspectiveTransform(p, self.plane_homography).reshape(-1, 2)

    def to_dict(self) -> dict:
        return {
            "camera_matrix": self.camera_matrix.tolist(),
            "distortion": self.distortion.ravel().tolist(),
            "rms_px": self.rms_px,
            "plane_homography": self.plane_homography.tolist(),
            "image_size": list(self.image_size),
        }

    def save(self, path) -> Path:
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=1))
        return path

    @classmethod
    def load(cls, path) -> Calibration:
        path = Path(path)
        try:
            d = json.loads(path.read_text(encoding="utf-8"))
            return cls(
                np.array(d["camera_matrix"], float),
                np.array(d["distortion"], float),
                float(d["rms_px"]),
                np.array(d["plane_homography"], float),
                tuple(d["image_size"]),
            )
        except FileNotFoundError:
            raise InputError(f"calibration file {path} not found") from None
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{path}: not a porosense camera calibration ({exc})") from None


def find_corners(gray: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    """Inner corners (N, 2) of a checkerboard with ``pattern`` = (columns, rows) inner corners."""
    found, corners = cv2.findChessboardCorners(
        gray, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    )
    if not found:
        return None
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)
    return cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), crit).reshape(-1, 2)


def calibrate(images, pattern: tuple[int, int], square_mm: float) -> Calibration:
    """Calibrate from 8-bit grey ``images`` of a checkerboard (``square_mm`` squares).

    The last image must show the board in the actuator's plane: its pose defines plane mm.
    """
    cols, rows = pattern
    grid = np.zeros((cols * rows, 3), np.float32)
    grid[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * float(square_mm)
    obj, img, size = [], [], None
    for i, gray in enumerate(images):
        size = gray.shape[::-1]
        corners = find_corners(gray, pattern)
        if corners is None:
            if i == len(images) - 1:
                raise InputError(f"checkerboard {cols}x{rows} not found in the last (plane) image")
            continue
        obj.append(grid)
        img.append(corners.astype(np.float32))
    if len(obj) < 3:
        raise InputError(f"checkerboard {cols}x{rows} found in {len(obj)} images; calibration needs at least 3")
    rms, k, dist, _, _ = cv2.calibrateCamera(obj, img, size, None, None)
    plane_px = cv2.undistortPoints(img[-1].reshape(-1, 1, 2).astype(np.float64), k, dist, P=k).reshape(-1, 2)
    hom, _ = cv2.findHomography(plane_px, grid[:, :2].astype(np.float64))
    return Calibration(k, dist, float(rms), hom, tuple(size))
