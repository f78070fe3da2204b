"""Actuator designs as data: regions of target porosity inside a printed part.

A design is a list of regions, each a prism (a circle or a rectangle in x-y, extruded from
z0 to z1) with a target porosity. Regions at or below ``BULK_LIMIT_PCT`` are printed
conventionally (rectilinear lines at a density 1 - phi/100); above it they are coiled.
All lengths in mm, porosity in %.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import InputError

#: Porosity (%) up to which a region is printed with conventional lines instead of coils.
BULK_LIMIT_PCT = 50.0


@dataclass(frozen=True)
class Circle:
    """Disc of radius r centred on (cx, cy), mm."""

    r: float
    cx: float = 0.0
    cy: float = 0.0

    def span(self, axis: int, coord: float) -> tuple[float, float] | None:
        """Interval covered on the line {other axis = coord} running along ``axis`` (0 x, 1 y)."""
        c_along, c_across = (self.cx, self.cy) if axis == 0 else (self.cy, self.cx)
        d = coord - c_across
        if abs(d) >= self.r:
            return None
        half = float(np.sqrt(self.r**2 - d**2))
        return c_along - half, c_along + half

    def bounds(self) -> tuple[float, float, float, float]:
        return self.cx - self.r, self.cx + self.r, self.cy - self.r, self.cy + self.r

    @property
    def area(self) -> float:
        return float(np.pi * self.r**2)


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle [x0, x1] x [y0, y1], mm."""

    x0: float
    x1: float
    y0: float
    y1: float

    def span(self, axis: int, coord: float) -> tuple[float, float] | None:
        lo_a, hi_a, lo_c, hi_c = (self.x0, self.x1, self.y0, self.y1) if axis == 0 else (self.y0, self.y1, self.x0, self.x1)
        if not lo_c <= coord <= hi_c:
            return None
        return lo_a, hi_a

    def bounds(self) -> tuple[float, float, float, float]:
        return self.x0, self.x1, self.y0, self.y1

    @property
    def area(self) -> float:
        return (self.x1 - self.x0) * (self.y1 - self.y0)


@dataclass(frozen=True)
class Region:
    """A prism of ``shape`` from z0 to z1 (mm) printed at ``porosity`` (%)."""

    name: str
    shape: Circle | Rect
    z0: float
    z1: float
    porosity: float

    @property
    def method(self) -> str:
        """'bulk' (conventional lines) or 'coil' (liquid rope coiling)."""
        return "bulk" if self.porosity <= BULK_LIMIT_PCT else "coil"

    @property
    def volume(self) -> float:
        """Envelope volume in mm^3."""
        return self.shape.area * (self.z1 - self.z0)


@dataclass(frozen=True)
class Design:
    """A printable actuator: its regions, and the actuator type the simulator knows it as."""

    name: str
    actuator: str  # "contractor" or "bending"
    regions: tuple[Region, ...]
    notes: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.regions:
            raise InputError(f"design {self.name!r} has no regions")
        for r in self.regions:
            if r.z1 <= r.z0:
                raise InputError(f"region {r.name!r}: z1 ({r.z1}) must be above z0 ({r.z0})")
            if not 0.0 <= r.porosity < 100.0:
                raise InputError(f"region {r.name!r}: porosity {r.porosity} % outside 0..100")

    @property
    def height(self) -> float:
        return max(r.z1 for r in self.regions)

    def bounds(self) -> tuple[float, float, float, float]:
        """x0, x1, y0, y1 over all regions (mm)."""
        b = np.array([r.shape.bounds() for r in self.regions])
        return float(b[:, 0].min()), float(b[:, 1].max()), float(b[:, 2].min()), float(b[:, 3].max())

    def foam_porosity(self) -> float:
        """Volume-weighted porosity (%) of the coiled regions: what sets stroke and sensitivity."""
        foam = [r for r in self.regions if r.method == "coil"]
        if not foam:
            return 0.0
        v = np.array([r.volume for r in foam])
        return float(np.sum(v * [r.porosity for r in foam]) / v.sum())

    def mean_porosity(self) -> float:
        """Volume-weighted porosity (%) of the whole part."""
        v = np.array([r.volume for r in self.regions])
        return float(np.sum(v * [r.porosity for r in self.regions]) / v.sum())

    # ---------------------------------------------------------------- I/O
    def to_dict(self) -> dict:
        regions = []
        for r in self.regions:
            d = asdict(r)
            d["shape"] = {"type": type(r.shape).__name__.lower(), **asdict(r.shape)}
            regions.append(d)
        return {"format": "porosense-design", "version": 1, "name": self.name, "actuator": self.actuator,
                "notes": self.notes, "regions": regions}

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    @classmethod
    def from_dict(cls, d: dict, source: str = "design") -> Design:
        try:
            regions = []
            for r in d["regions"]:
                s = dict(r["shape"])
                kind = s.pop("type")
                shape = {"circle": Circle, "rect": Rect}[kind](**s)
                regions.append(Region(r["name"], shape, float(r["z0"]), float(r["z1"]), float(r["porosity"])))
            return cls(d["name"], d.get("actuator", "contractor"), tuple(regions), d.get("notes", ""))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{source}: not a valid design ({exc!r})") from None

    @classmethod
    def load(cls, path) -> Design:
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise InputError(f"{path}: no such design file") from None
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
        return cls.from_dict(data, str(path))


def paper_contractor(foam_porosity: float = 76.0, ring_porosity: float = 30.0, ring_mm: float = 1.5) -> Design:
    """The paper's contractor: cylinder 25 mm in diameter and 50 mm tall, 5 mm bulk base and
    top, low-porosity rings at 14 and 28 mm, foam of ``foam_porosity`` (%) in between."""
    disc = Circle(12.5)
    z = [0.0, 5.0, 14.0, 14.0 + ring_mm, 28.0, 28.0 + ring_mm, 45.0, 50.0]
    regions = (
        Region("base", disc, z[0], z[1], 0.0),
        Region("foam_1", disc, z[1], z[2], foam_porosity),
        Region("ring_14", disc, z[2], z[3], ring_porosity),
        Region("foam_2", disc, z[3], z[4], foam_porosity),
        Region("ring_28", disc, z[4], z[5], ring_porosity),
        Region("foam_3", disc, z[5], z[6], foam_porosity),
        Region("top", disc, z[6], z[7], 0.0),
    )
    return Design("paper_contractor", "contractor", regions,
                  "Contractor of the paper: 25 mm x 50 mm cylinder, rings at 14 and 28 mm.")


def paper_bending(section_porosity: float = 84.0, spacer_porosity: float = 30.0, spacer_mm: float = 2.0) -> Design:
    """The paper's bending actuator: 1 mm bulk base under a 75 x 15 x 10 mm foam body made of
    four sections of ``section_porosity`` (%) separated by low-porosity spacers."""
    length, width, height, base = 75.0, 15.0, 10.0, 1.0
    y0, y1 = -width / 2, width / 2
    n = 4
    sec = (length - (n - 1) * spacer_mm) / n
    regions = [Region("base", Rect(-length / 2, length / 2, y0, y1), 0.0, base, 0.0)]
    x = -length / 2
    for i in range(n):
        regions.append(Region(f"section_{i + 1}", Rect(x, x + sec, y0, y1), base, base + height, section_porosity))
        x += sec
        if i < n - 1:
            regions.append(Region(f"spacer_{i + 1}", Rect(x, x + spacer_mm, y0, y1), base, base + height, spacer_porosity))
            x += spacer_mm
    return Design("paper_bending", "bending", tuple(regions),
                  "Bending actuator of the paper: 1 mm base, four 84 % sections, low-porosity spacers.")


EXAMPLES = {"contractor": paper_contractor, "bending": paper_bending}


def get_design(spec: str) -> Design:
    """A built-in example by name (contractor, bending) or a design JSON file path."""
    if spec in EXAMPLES:
        return EXAMPLES[spec]()
    if Path(spec).suffix.lower() == ".json" or Path(spec).exists():
        return Design.load(spec)
    raise InputError(f"unknown design {spec!r}: give a design JSON file or one of {', '.join(EXAMPLES)}")
