"""Printable PLA fixtures as meshes, generated from the actuators' dimensions (mm).

Built with trimesh (mesh container, STL export, watertightness checks) and its manifold3d
boolean engine, which returns closed 2-manifold solids from every union and difference. Each
part is modelled in its print orientation (lying on z = 0) and carries the features the
assembly guide refers to:

- ``bending_holder``: clamp for the bending actuator's solid end (spacer 1), with the vacuum
  tube port, the hole for the top-left electrode wire and a flange with two M4 holes;
- ``contractor_hanger``: cup over the contractor's 5 mm solid top with the vacuum port, on an
  arm with two M5 holes to hang it from a frame;
- ``contractor_load_hook``: cup under the contractor's 5 mm solid base with a hook for the
  200 g / 500 g loads (printed cup-down, hook up);
- ``segment_base``: plate with three cups on the 52 mm triangle for the contractors' bases,
  vacuum ports through, three M4 holes;
- ``segment_stage``: plate with three cups for the contractors' tops and, on the face that is
  up in use (on the bed when printed), the BNO055 pocket with a cable notch, its axes on the
  segment's x and y.

Cups are as deep as the actuators' solid ends (5 mm), so the foam stays free to contract.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import InputError
from porosense.infoam import design as D

#: SEBS sleeve wall (mm), heat-sealed around every actuator.
SLEEVE_MM = 0.4
#: Radial/side clearance (mm) between a sleeved actuator and a PLA cup or slot.
FIT_MM = 0.2
WALL_MM = 3.0
FLOOR_MM = 4.0
TUBE_HOLE_MM = 4.2  # 4 mm OD vacuum tube
WIRE_HOLE_MM = 1.5  # copper electrode wire with its insulation
M4_HOLE_MM = 4.4
M5_HOLE_MM = 5.4
#: BNO055 breakout outline (Adafruit 2472: 26.7 x 20.3 mm), pocket depth (mm).
BNO055_BOARD_MM = (26.7, 20.3)
BNO055_POCKET_DEPTH_MM = 1.6
SECTIONS = 96  # facets per full circle

PLA_DENSITY_G_CM3 = 1.24


def cup_inner_diameter() -> float:
    """Inner diameter (mm) of a cup around a sleeved 25 mm contractor."""
    return D.CONTRACTOR_DIAMETER_MM + 2 * (SLEEVE_MM + FIT_MM)


def bending_slot() -> tuple[float, float]:
    """Width and height (mm) of the slot around the sleeved bending actuator's cross-section."""
    _, width, height = D.BENDING_BODY_MM
    return width + 2 * (SLEEVE_MM + FIT_MM), D.BENDING_BASE_MM + height + 2 * (SLEEVE_MM + FIT_MM)


# ---------------------------------------------------------------- primitives
def _box(x0, x1, y0, y1, z0, z1):
    import trimesh

    if not (x1 > x0 and y1 > y0 and z1 > z0):
        raise InputError(f"zero or negative box {x1 - x0:g} x {y1 - y0:g} x {z1 - z0:g} mm")
    return trimesh.creation.box(
        extents=(x1 - x0, y1 - y0, z1 - z0), transform=_move((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    )


def _cyl(r, z0, z1, cx=0.0, cy=0.0, axis="z"):
    """Cylinder of radius r (mm) from z0 to z1 along ``axis`` (z, or y: then z0..z1 are y)."""
    import trimesh

    if not (r > 0 and z1 > z0):
        raise InputError(f"zero or negative cylinder r {r:g} mm, length {z1 - z0:g} mm")
    c = trimesh.creation.cylinder(radius=r, height=z1 - z0, sections=SECTIONS)
    if axis == "y":
        rot = trimesh.transformations.rotation_matrix(math.pi / 2, (1, 0, 0))
        c.apply_transform(rot)
        c.apply_translation((cx, (z0 + z1) / 2, cy))
    else:
        c.apply_translation((cx, cy, (z0 + z1) / 2))
    return c


def _move(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def _union(*meshes):
    import trimesh

    return trimesh.boolean.union(list(meshes), engine="manifold")


def _minus(a, *cutters):
    import trimesh

    return trimesh.boolean.difference([a, *cutters], engine="manifold")


def _cup(cx, cy, z_floor, depth, port: bool):
    """Solid ring of a cup (outer wall) and its bore and optional port, as (solid, cutters)."""
    ri = cup_inner_diameter() / 2
    solid = _cyl(ri + WALL_MM, 0.0, z_floor + depth, cx, cy)
    cutters = [_cyl(ri, z_floor, z_floor + depth + 1.0, cx, cy)]
    if port:
        cutters.append(_cyl(TUBE_HOLE_MM / 2, -1.0, z_floor + 1.0, cx, cy))
    return solid, cutters


# ---------------------------------------------------------------- parts
def bending_holder(grip_mm: float = 10.0):
    """Clamp for the bending actuator's end: slot along +x, ``grip_mm`` (mm) deep."""
    if grip_mm <= 0:
        raise InputError(f"grip depth {grip_mm} mm must be positive")
    sw, sh = bending_slot()
    back, wall, flange_w, flange_t = 4.0, 4.0, 12.0, 4.0
    length = back + grip_mm
    body = _box(0.0, length, -sw / 2 - wall, sw / 2 + wall, 0.0, sh + 2 * wall)
    flange = _box(0.0, length, -sw / 2 - wall - flange_w, sw / 2 + wall + flange_w, 0.0, flange_t)
    slot = _box(back, length + 1.0, -sw / 2, sw / 2, wall, wall + sh)
    # Tube enters the foam at mid-height; the top-left electrode wire leaves above it.
    tube = _box(
        -1.0,
        back + 0.5,
        -TUBE_HOLE_MM / 2,
        TUBE_HOLE_MM / 2,
        wall + sh / 2 - TUBE_HOLE_MM / 2,
        wall + sh / 2 + TUBE_HOLE_MM / 2,
    )
    wire = _box(
        -1.0, back + 0.5, -sw / 2 + 1.0, -sw / 2 + 1.0 + WIRE_HOLE_MM, wall + sh - 1.0 - WIRE_HOLE_MM, wall + sh - 1.0
    )
    y_hole = sw / 2 + wall + flange_w / 2
    holes = [_cyl(M4_HOLE_MM / 2, -1.0, flange_t + 1.0, length / 2, s * y_hole) for s in (-1, 1)]
    return _minus(_union(body, flange), slot, tube, wire, *holes)


def contractor_hanger(arm_mm: float = 70.0):
    """Cup over the contractor's top (printed floor down), on an arm ``arm_mm`` (mm) long."""
    if arm_mm <= cup_inner_diameter() + 2 * WALL_MM + 4 * M5_HOLE_MM:
        raise InputError(f"arm {arm_mm} mm too short for the cup and two M5 holes")
    solid, cutters = _cup(0.0, 0.0, FLOOR_MM, D.CONTRACTOR_END_MM, port=True)
    arm = _box(-arm_mm / 2, arm_mm / 2, -7.0, 7.0, 0.0, FLOOR_MM)
    x_hole = arm_mm / 2 - M5_HOLE_MM
    holes = [_cyl(M5_HOLE_MM / 2, -1.0, FLOOR_MM + 1.0, s * x_hole, 0.0) for s in (-1, 1)]
    wire = _cyl(WIRE_HOLE_MM / 2, -1.0, FLOOR_MM + 1.0, cup_inner_diameter() / 2 - 2.0, 0.0)
    return _minus(_union(solid, arm), *cutters, *holes, wire)


def contractor_load_hook(hook_inner_mm: float = 10.0, gap_mm: float = 5.0):
    """Cup under the contractor's base with a hook (inner diameter ``hook_inner_mm``, opening
    ``gap_mm``, mm) for the loads; printed cup opening down, hook up."""
    if not 0 < gap_mm < hook_inner_mm:
        raise InputError(f"hook opening {gap_mm} mm must lie between 0 and its inner diameter {hook_inner_mm} mm")
    ri = cup_inner_diameter() / 2
    depth = D.CONTRACTOR_END_MM
    cup = _cyl(ri + WALL_MM, 0.0, depth + FLOOR_MM, 0.0, 0.0)
    bore = _cyl(ri, -1.0, depth, 0.0, 0.0)
    wire = _cyl(WIRE_HOLE_MM / 2, depth - 0.5, depth + FLOOR_MM + 1.0, ri - 2.0, 0.0)
    thick, ring = 6.0, 4.0
    r_in = hook_inner_mm / 2
    z_top = depth + FLOOR_MM
    stem = _box(-3.0, 3.0, -thick / 2, thick / 2, z_top - 0.5, z_top + 4.0)
    zc = z_top + 4.0 + r_in + ring - 0.5
    outer = _cyl(r_in + ring, -thick / 2, thick / 2, 0.0, zc, axis="y")
    inner = _cyl(r_in, -thick / 2 - 1, thick / 2 + 1, 0.0, zc, axis="y")
    # The opening: a slot through the ring's upper side, on +x.
    opening = _box(0.0, r_in + ring + 1.0, -thick / 2 - 1, thick / 2 + 1, zc, zc + gap_mm)
    hook = _minus(outer, inner, opening)
    return _minus(_union(cup, stem, hook), bore, wire)


def _segment_plate(side_mm: float):
    ri = cup_inner_diameter() / 2
    corners = D.segment_corners_mm(side_mm)
    r_corner = side_mm / math.sqrt(3.0)
    r_plate = r_corner + ri + WALL_MM + 2.0
    return corners, r_corner, r_plate


def segment_base(side_mm: float = D.SEGMENT_SIDE_MM):
    """Base of the 3-DoF segment: three cups (vacuum port through each) on the triangle of
    side ``side_mm`` (mm) and three M4 holes between them."""
    corners, r_corner, r_plate = _segment_plate(side_mm)
    r_hole_ring = r_plate + 6.0
    plate = _cyl(r_hole_ring + 6.0, 0.0, FLOOR_MM)
    solids, cutters = [plate], []
    for x, y in corners:
        s, c = _cup(x, y, FLOOR_MM, D.CONTRACTOR_END_MM, port=True)
        solids.append(s)
        cutters += c
    from porosense.sim.kinematics import CORNER_ANGLES_DEG

    for a in CORNER_ANGLES_DEG:  # holes opposite the corners, clear of every cup
        t = math.radians(a + 180.0)
        cutters.append(_cyl(M4_HOLE_MM / 2, -1.0, FLOOR_MM + 1.0, r_hole_ring * math.cos(t), r_hole_ring * math.sin(t)))
    return _minus(_union(*solids), *cutters)


def segment_stage(side_mm: float = D.SEGMENT_SIDE_MM):
    """Stage of the 3-DoF segment: three cups for the contractors' tops (printed floor down)
    and the BNO055 pocket in the floor's underside, which is the stage's top in use."""
    corners, _, r_plate = _segment_plate(side_mm)
    plate = _cyl(r_plate, 0.0, FLOOR_MM)
    solids, cutters = [plate], []
    for x, y in corners:
        s, c = _cup(x, y, FLOOR_MM, D.CONTRACTOR_END_MM, port=False)
        solids.append(s)
        cutters += c
    bx, by = (v + 2 * FIT_MM for v in BNO055_BOARD_MM)
    # Centred on the segment's axis, board edges along x and y: flipping the stage keeps both.
    cutters.append(_box(-bx / 2, bx / 2, -by / 2, by / 2, -1.0, BNO055_POCKET_DEPTH_MM))
    cutters.append(_box(bx / 2 - 1.0, r_plate + 1.0, -4.0, 4.0, -1.0, BNO055_POCKET_DEPTH_MM))  # cable notch
    return _minus(_union(*solids), *cutters)


@dataclass
class Part:
    """A generated fixture: its mesh (mm) and what it is for."""

    name: str
    purpose: str
    mesh: object = field(repr=False)

    @property
    def size_mm(self) -> tuple[float, float, float]:
        return tuple(float(v) for v in self.mesh.extents)

    def to_dict(self) -> dict:
        m = self.mesh
        return {
            "name": self.name,
            "purpose": self.purpose,
            "size_mm": list(self.size_mm),
            "volume_cm3": float(m.volume) / 1000.0,
            "mass_g": float(m.volume) / 1000.0 * PLA_DENSITY_G_CM3,
            "watertight": bool(m.is_watertight),
            "triangles": int(len(m.faces)),
            "material": "pla",
        }

    def write(self, folder) -> dict:
        """Write ``<name>.stl`` into ``folder``; return to_dict() with the file name."""
        path = Path(folder) / f"{self.name}.stl"
        self.mesh.export(path)
        return {"file": path.name, **self.to_dict()}


PARTS = {
    "bending_holder": (bending_holder, "PLA holder clamping the bending actuator's solid end"),
    "contractor_hanger": (contractor_hanger, "hangs the contractor by its solid top; vacuum port"),
    "contractor_load_hook": (contractor_load_hook, "cup on the contractor's base with the hook for 200/500 g loads"),
    "segment_base": (segment_base, "3-DoF base: three contractor cups on the 52 mm triangle, vacuum ports"),
    "segment_stage": (segment_stage, "3-DoF stage: three contractor cups and the BNO055 mount"),
}


def build_part(name: str, machine=None) -> Part:
    """Generate one part; InputError when it is not a closed solid or does not fit ``machine``."""
    if name not in PARTS:
        raise InputError(f"unknown part {name!r}: known are {', '.join(PARTS)}")
    make, purpose = PARTS[name]
    mesh = make()
    if not (mesh.is_watertight and mesh.is_volume):
        raise InputError(f"part {name}: the mesh is not a closed solid")  # a modelling bug, said plainly
    part = Part(name, purpose, mesh)
    if machine is not None:
        machine.check_fits(f"part {name}", *part.size_mm)
    return part


def build_parts(names=None, machine=None) -> list[Part]:
    """Generate the named parts (all by default)."""
    return [build_part(n, machine) for n in (names or list(PARTS))]
