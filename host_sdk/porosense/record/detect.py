"""Dark features (stripes, markers, reference dots) on a lighter background.

A black-hat transform (closing minus image) with a window wider than the features removes the
slowly varying illumination, so one contrast threshold works across the image; centroids are
weighted by the black-hat contrast, which gives sub-pixel positions on blurred edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass
class Blob:
    """A dark feature: centroid (px, full-image coordinates), area (px) and peak contrast."""

    x: float
    y: float
    area: float
    contrast: float


def dark_blobs(gray: np.ndarray, roi, feature_px: int, min_contrast: float, min_area: float = 4.0) -> list[Blob]:
    """Dark blobs inside ``roi`` (x, y, w, h) of an 8-bit image, largest first.

    ``feature_px`` is the largest feature size (px); ``min_contrast`` the darkening (grey
    levels) below which nothing counts as a feature, whatever the image's own statistics.
    """
    x0, y0, w, h = (int(v) for v in roi)
    sub = gray[y0 : y0 + h, x0 : x0 + w]
    if sub.size == 0:
        return []
    k = int(feature_px) | 1
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k + 2, k + 2))
    hat = cv2.morphologyEx(sub, cv2.MORPH_BLACKHAT, kernel)
    otsu, _ = cv2.threshold(hat, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    level = max(float(otsu), float(min_contrast))
    binary = (hat > level).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=8)
    out = []
    weight = hat.astype(np.float32) - np.float32(level / 2)
    for i in range(1, n):
        bx, by, bw, bh, area = stats[i]
        if area < min_area:
            continue
        # Weighted centroid over the component grown by one pixel (keeps the soft edges).
        xa, ya = max(bx - 1, 0), max(by - 1, 0)
        xb, yb = min(bx + bw + 1, w), min(by + bh + 1, h)
        mask = cv2.dilate((labels[ya:yb, xa:xb] == i).astype(np.uint8), np.ones((3, 3), np.uint8))
        wgt = np.where(mask > 0, np.maximum(weight[ya:yb, xa:xb], 0), 0).astype(np.float32)
        m = cv2.moments(wgt)
        if m["m00"] <= 0:
            continue
        out.append(
            Blob(
                m["m10"] / m["m00"] + xa + x0,
                m["m01"] / m["m00"] + ya + y0,
                float(area),
                float(hat[ya:yb, xa:xb][mask > 0].max()),
            )
        )
    out.sort(key=lambda b: -b.area)
    return out
