"""Actuator designs as data: regions of target porosity inside a printed part.

A design is a list of regions, each a prism (a circle, an annulus or a rectangle in x-y,
extruded from z0 to z1) with a target porosity. Regions at or below ``BULK_LIMIT_PCT`` are printed
conventionally (rectilinear lines at a density 1 - phi/100); above it they are coiled.
All lengths in mm, porosity in %.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import InputError
from porosense.files import write_text

#: Porosity (%) up to which a region is printed with conventional lines instead of coils.
BULK_LIMIT_PCT = 50.0


@dataclass(frozen=True)
class Circle:
    """Disc of radius r centred on (cx, cy), mm."""

    r: float
    cx: float = 0.0
    cy: float = 0.0

    def spans(self, axis: int, coord: float) -> list[tuple[float, float]]:
        """Intervals covered on the line {other axis = coord} running along ``axis`` (0 x, 1 y)."""
        c_along, c_across = (self.cx, self.cy) if axis == 0 else (self.cy, self.cx)
        d = coord - c_across
        if abs(d) >= self.r:
            return []
        half = float(np.sqrt(self.r**2 - d**2))
        return [(c_along - half, c_along + half)]

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

    def spans(self, axis: int, coord: float) -> list[tuple[float, float]]:
        lo_a, hi_a, lo_c, hi_c = (
            (self.x0, self.x1, self.y0, self.y1) if axis == 0 else (self.y0, self.y1, self.x0, self.x1)
        )
        if not lo_c <= coord <= hi_c:
            return []
        return [(lo_a, hi_a)]

    def bounds(self) -> tuple[float, float, float, float]:
        return self.x0, self.x1, self.y0, self.y1

    @property
    def area(self) -> float:
        return (self.x1 - self.x0) * (self.y1 - self.y0)


@dataclass(frozen=True)
class Annulus:
    """Ring between radii r_in and r (outer) centred on (cx, cy), mm."""

    r: float
    r_in: float
    cx: float = 0.0
    cy: float = 0.0

    def __post_init__(self):
        if not 0.0 < self.r_in < self.r:
            raise InputError(f"annulus needs 0 < r_in < r (got r_in {self.r_in} mm, r {self.r} mm)")

    def spans(self, axis: int, coord: float) -> list[tuple[float, float]]:
        outer = Circle(self.r, self.cx, self.cy).spans(axis, coord)
        inner = Circle(self.r_in, self.cx, self.cy).spans(axis, coord)
        if not outer:
            return []
        if not inner:
            return outer
        (a, b), (c, d) = outer[0], inner[0]
        return [(a, c), (d, b)]

    def bounds(self) -> tuple[float, float, float, float]:
        return self.cx - self.r, self.cx + self.r, self.cy - self.r, self.cy + self.r

    @property
    def area(self) -> float:
        return float(np.pi * (self.r**2 - self.r_in**2))


SHAPES = {"circle": Circle, "annulus": Annulus, "rect": Rect}


@dataclass(frozen=True)
class Region:
    """A prism of ``shape`` from z0 to z1 (mm) printed at ``porosity`` (%)."""

    name: str
    shape: Circle | Annulus | Rect
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
            x0, x1, y0, y1 = r.shape.bounds()
            if not (x1 > x0 and y1 > y0 and r.shape.area > 0):
                raise InputError(f"region {r.name!r}: zero or negative size in x-y ({r.shape})")
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
        return {
            "format": "porosense-design",
            "version": 1,
            "name": self.name,
            "actuator": self.actuator,
            "notes": self.notes,
            "regions": regions,
        }

    def save(self, path) -> Path:
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    @classmethod
    def from_dict(cls, d: dict, source: str = "design") -> Design:
        try:
            regions = []
            for r in d["regions"]:
                s = dict(r["shape"])
                kind = s.pop("type")
                shape = SHAPES[kind](**s)
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


#: The paper's contractor: cylinder (mm), bulk ends (mm), ring heights and width (mm).
CONTRACTOR_DIAMETER_MM = 25.0
CONTRACTOR_HEIGHT_MM = 50.0
CONTRACTOR_END_MM = 5.0
CONTRACTOR_RING_Z_MM = (14.0, 28.0)
CONTRACTOR_RING_MM = 5.6
#: Radial wall of the rings (mm). The paper gives their height and position, not their wall;
#: a ring keeps the foam core open so the vacuum reaches every foam section.
CONTRACTOR_RING_WALL_MM = 2.5
#: Porosity (%) printed for "bulk" and "near zero porosity" parts (the paper: below 5 %).
SOLID_PCT = 0.0
#: Diameter (mm) of the channel left through one solid end for the 4 mm OD vacuum tube.
PORT_MM = 4.2


def paper_contractor(
    foam_porosity: float = 76.0,
    ring_porosity: float = SOLID_PCT,
    ring_mm: float = CONTRACTOR_RING_MM,
    ring_wall_mm: float = CONTRACTOR_RING_WALL_MM,
    *,
    port_end: str = "top",
    cx: float = 0.0,
    cy: float = 0.0,
    prefix: str = "",
) -> Design:
    """The paper's contractor: a cylinder 25 mm in diameter and 50 mm tall; 5 mm base and top
    printed solid; low-porosity rings ``ring_mm`` (5.6 mm) tall whose lower edges sit at 14 and
    28 mm, ``ring_wall_mm`` thick at the rim, with foam of ``foam_porosity`` (%) everywhere else
    (the core inside the rings too). The ``port_end`` ("top" or "base") keeps a PORT_MM channel
    on the axis for the vacuum tube. ``cx``, ``cy`` (mm) place it; ``prefix`` names its regions."""
    if port_end not in ("top", "base"):
        raise InputError(f"port_end must be 'top' or 'base', not {port_end!r}")
    r = CONTRACTOR_DIAMETER_MM / 2.0
    if not 0.0 < ring_wall_mm < r:
        raise InputError(f"ring wall {ring_wall_mm} mm must lie between 0 and the radius {r} mm")
    if ring_mm <= 0:
        raise InputError(f"ring height {ring_mm} mm must be positive")
    disc = Circle(r, cx, cy)
    ring = Annulus(r, r - ring_wall_mm, cx, cy)
    core = Circle(r - ring_wall_mm, cx, cy)
    end, top = CONTRACTOR_END_MM, CONTRACTOR_HEIGHT_MM - CONTRACTOR_END_MM
    edges = [end]
    for z in CONTRACTOR_RING_Z_MM:
        edges += [z, z + ring_mm]
    edges.append(top)
    if any(b <= a for a, b in zip(edges, edges[1:])):
        raise InputError(f"rings of {ring_mm} mm at {CONTRACTOR_RING_Z_MM} mm overlap each other or the ends")
    n = prefix
    ported = Annulus(r, PORT_MM / 2.0, cx, cy)
    regions = [Region(f"{n}base", ported if port_end == "base" else disc, 0.0, end, SOLID_PCT)]
    for k, z in enumerate(CONTRACTOR_RING_Z_MM):
        regions.append(Region(f"{n}foam_{k + 1}", disc, edges[2 * k], z, foam_porosity))
        regions.append(Region(f"{n}ring_{z:g}", ring, z, z + ring_mm, ring_porosity))
        regions.append(Region(f"{n}core_{z:g}", core, z, z + ring_mm, foam_porosity))
    regions.append(Region(f"{n}foam_{len(CONTRACTOR_RING_Z_MM) + 1}", disc, edges[-2], top, foam_porosity))
    regions.append(Region(f"{n}top", ported if port_end == "top" else disc, top, CONTRACTOR_HEIGHT_MM, SOLID_PCT))
    return Design(
        "paper_contractor",
        "contractor",
        tuple(regions),
        "Contractor of the paper: 25 mm x 50 mm cylinder, solid 5 mm ends, "
        f"{ring_mm:g} mm low-porosity rings at 14 and 28 mm.",
    )


#: The paper's bending actuator (mm): base, foam body, and the spacers between its sections.
BENDING_BASE_MM = 1.0
BENDING_BODY_MM = (75.0, 15.0, 10.0)  # length x width x height of the porous body
BENDING_SECTIONS = 4
#: Spacer length along the actuator (mm): not given in the paper; a few conventional lines.
BENDING_SPACER_MM = 2.0


def paper_bending(
    section_porosity: float = 84.0, spacer_porosity: float = SOLID_PCT, spacer_mm: float = BENDING_SPACER_MM
) -> Design:
    """The paper's bending actuator: a 1 mm solid base under a 75 x 15 x 10 mm porous body of
    four sections of ``section_porosity`` (%), each preceded by a low-porosity spacer of
    ``spacer_mm``; the first spacer is the clamped end (x = -37.5 mm), the tip is foam."""
    length, width, height = BENDING_BODY_MM
    base = BENDING_BASE_MM
    n = BENDING_SECTIONS
    if not 0.0 < spacer_mm < length / n:
        raise InputError(f"spacer {spacer_mm} mm must lie between 0 and {length / n:g} mm")
    y0, y1 = -width / 2, width / 2
    sec = (length - n * spacer_mm) / n
    regions = [Region("base", Rect(-length / 2, length / 2, y0, y1), 0.0, base, SOLID_PCT)]
    x = -length / 2
    for i in range(n):
        regions.append(Region(f"spacer_{i + 1}", Rect(x, x + spacer_mm, y0, y1), base, base + height, spacer_porosity))
        x += spacer_mm
        regions.append(Region(f"section_{i + 1}", Rect(x, x + sec, y0, y1), base, base + height, section_porosity))
        x += sec
    return Design(
        "paper_bending",
        "bending",
        tuple(regions),
        "Bending actuator of the paper: 1 mm base, 75 x 15 x 10 mm body of four "
        f"{section_porosity:g} % sections and four low-porosity spacers.",
    )


#: The 3-DoF segment: contractors on an equilateral triangle of this side (mm).
SEGMENT_SIDE_MM = 52.0
SEGMENT_POROSITY = 76.0


def segment_corners_mm(side_mm: float = SEGMENT_SIDE_MM) -> list[tuple[float, float]]:
    """x, y (mm) of the three contractors, at the simulator's corner angles (90, 210, 330 deg)."""
    from porosense.sim.kinematics import CORNER_ANGLES_DEG

    r = side_mm / np.sqrt(3.0)
    return [(float(r * np.cos(np.radians(a))), float(r * np.sin(np.radians(a)))) for a in CORNER_ANGLES_DEG]


def paper_segment(foam_porosity: float = SEGMENT_POROSITY, side_mm: float = SEGMENT_SIDE_MM) -> Design:
    """The 3-DoF segment's three contractors (regions ``c1_``, ``c2_``, ``c3_``) printed in one
    job at their places on the triangle of side ``side_mm`` (mm), so the print shows the layout."""
    if side_mm <= CONTRACTOR_DIAMETER_MM:
        raise InputError(f"triangle side {side_mm} mm leaves no room between 25 mm contractors")
    regions = []
    for k, (x, y) in enumerate(segment_corners_mm(side_mm)):
        regions += paper_contractor(foam_porosity, port_end="base", cx=x, cy=y, prefix=f"c{k + 1}_").regions
    return Design(
        "paper_segment",
        "contractor",
        tuple(regions),
        f"3-DoF segment: three {foam_porosity:g} % contractors on a {side_mm:g} mm triangle.",
        {"side_mm": side_mm},
    )


EXAMPLES = {"contractor": paper_contractor, "bending": paper_bending, "segment": paper_segment}


def get_design(spec: str) -> Design:
    """A built-in example by name (contractor, bending) or a design JSON file path."""
    if spec in EXAMPLES:
        return EXAMPLES[spec]()
    if Path(spec).suffix.lower() == ".json" or Path(spec).exists():
        return Design.load(spec)
    raise InputError(f"unknown design {spec!r}: give a design JSON file or one of {', '.join(EXAMPLES)}")
