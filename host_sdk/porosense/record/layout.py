"""Where the tracked things are in the image, and how pixels become millimetres.

A layout is a small JSON file (docs/camera.md)::

    {"stripes": [x, y, w, h], "marker": [x, y, w, h], "indicator": [x, y, w, h],
     "reference": [x, y, w, h], "reference_mm": 100.0, "feature_px": 25,
     "min_contrast": 30, "max_failed_fraction": 0.1, "marker_length_mm": 50.0}

Regions are in pixels of the raw frame. ``reference`` holds two dark dots ``reference_mm``
apart in the actuator's plane (the scale); a checkerboard calibration replaces it.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from porosense.errors import InputError
from porosense.files import write_text

REGIONS = ("stripes", "marker", "indicator", "reference")


@dataclass
class Layout:
    """Regions (x, y, w, h) in px, the reference length (mm) and detection settings."""

    stripes: tuple | None = None
    marker: tuple | None = None
    indicator: tuple | None = None
    reference: tuple | None = None
    reference_mm: float | None = None
    feature_px: int = 25  # widest dark feature (stripe, marker), px
    min_contrast: float = 30.0  # darkening below which nothing is a feature, grey levels
    max_failed_fraction: float = 0.10  # more failed frames than this is an error
    marker_length_mm: float | None = None  # fixed end to marker at rest: strain = dz / this

    def __post_init__(self):
        for name in REGIONS:
            roi = getattr(self, name)
            if roi is None:
                continue
            if len(roi) != 4 or any(not isinstance(v, (int, float)) for v in roi) or roi[2] <= 0 or roi[3] <= 0:
                raise InputError(f"layout: '{name}' must be [x, y, w, h] in px with w, h > 0, got {roi}")
            setattr(self, name, tuple(int(v) for v in roi))
        if self.stripes is None and self.marker is None:
            raise InputError("layout: give a 'stripes' or a 'marker' region (nothing to track)")
        if self.reference is not None and not (self.reference_mm and self.reference_mm > 0):
            raise InputError("layout: 'reference' needs 'reference_mm' > 0 (the dots' distance in mm)")
        if not 0 <= self.max_failed_fraction < 1:
            raise InputError("layout: 'max_failed_fraction' must be in [0, 1)")

    @classmethod
    def load(cls, path) -> Layout:
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"layout file {path} not found") from None
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known) if isinstance(data, dict) else []
        if not isinstance(data, dict) or unknown:
            raise InputError(f"{path}: expected a JSON object with keys {sorted(known)}; unknown: {unknown}")
        return cls(**data)

    def save(self, path) -> Path:
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=1))
        return path

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}
