"""Toolpaths and G-code for graded-porosity parts printed by the InFoam method.

Bulk and low-porosity regions are printed conventionally: rectilinear lines one nozzle wide,
spaced by nozzle / (1 - phi/100), in layers of ``Machine.bulk_layer_mm``. Foam regions are
coiled: the nozzle runs at height H above the surface (from the porosity model), extruding
pi N mm of filament per mm of travel (N: coil density), along lines spaced by the coil pitch.
One coil layer is pi^2 d^2 / (4 c) thick, which is what makes the printed solid fraction equal
the calibrated c N / pitch. Heights and pitches are rounded to fit each region exactly; the
coil density is then trimmed so the printed porosity equals the target.

E values are in the machine's own unit (screw turns of a pellet extruder, mm^3 of melt, or
mm of filament; see ``profiles``), and a ``;MACHINE`` comment states the conversion so a
reader can turn E back into melt volume. Comments mark regions (``;REGION``) and layers
(``;LAYER``) so a reader can attribute every move; lengths in mm, speeds in mm/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from porosense.errors import InputError
from porosense.files import write_text
from porosense.infoam.calibration import PorosityModel, paper_calibration
from porosense.infoam.design import Design, Region
from porosense.infoam.profiles import DEFAULT_MACHINE, Machine, Material, load_machine, load_material

#: Coil densities the planner may use when a porosity is out of reach at the nominal N.
MIN_COIL_DENSITY = 1.0
MAX_COIL_DENSITY = 8.0


@dataclass(frozen=True)
class PrintSettings:
    """Everything the planner needs besides the design."""

    machine: Machine = field(default_factory=lambda: load_machine(DEFAULT_MACHINE))
    material: Material | None = None  # None: the machine profile's material
    porosity_model: PorosityModel = field(default_factory=paper_calibration)
    coil_density: float = 3.0

    def __post_init__(self):
        if self.material is None:
            object.__setattr__(self, "material", load_material(self.machine.material))
        self.machine.check_temperatures(self.material)
        if abs(self.porosity_model.nozzle_mm - self.machine.nozzle_mm) > 1e-9:
            raise InputError(
                f"the porosity calibration is for a {self.porosity_model.nozzle_mm:g} mm nozzle, "
                f"the machine {self.machine.name!r} has {self.machine.nozzle_mm:g} mm: recalibrate"
            )
        if not 0.5 <= self.coil_density <= 10:
            raise InputError(f"coil density {self.coil_density} outside 0.5..10")

    @property
    def strand_area(self) -> float:
        """Cross-section of the extruded strand (nozzle diameter), mm^2."""
        return math.pi * self.machine.nozzle_mm**2 / 4.0

    @property
    def coil_layer_mm(self) -> float:
        """Thickness of one coiled layer implied by the calibration, mm."""
        return math.pi * self.strand_area / self.porosity_model.c_mm


@dataclass(frozen=True)
class RegionPlan:
    """How one region is printed and what it should weigh."""

    region: Region
    method: str
    layer_mm: float
    n_layers: int
    pitch_mm: float  # between lines running along x (tiles the y extent)
    pitch_x_mm: float  # between lines running along y (bulk layers alternate direction)
    nozzle_height_mm: float  # above the surface being printed on (coil) or the layer height (bulk)
    coil_density: float  # N actually used (coil), 0 for bulk
    volume_per_mm: float  # strand volume per mm of travel along x, mm^3/mm
    speed_mm_s: float
    porosity: float  # predicted porosity of the printed region, %
    volume_per_mm_y: float = 0.0  # ... along y (bulk layers that alternate direction), mm^3/mm

    def volume_per_mm_along(self, axis: int) -> float:
        """Strand volume per mm of travel (mm^3/mm) for lines along ``axis`` (0 x, 1 y)."""
        return self.volume_per_mm if axis == 0 else self.volume_per_mm_y

    @property
    def strand_width_mm(self) -> float:
        """Width (mm) of a bulk strand (volume per mm / layer height); 0 for coils."""
        return self.volume_per_mm / self.layer_mm if self.method == "bulk" else 0.0

    @property
    def solid_volume(self) -> float:
        """Predicted solid volume of the region, mm^3."""
        return self.region.volume * (1.0 - self.porosity / 100.0)


@dataclass
class PrintJob:
    """The G-code text, the plans behind it and the extruding segments (for the preview)."""

    design: Design
    settings: PrintSettings
    plans: list[RegionPlan]
    gcode: str
    segments: np.ndarray  # (n, 9): x0 y0 z0 x1 y1 z1 (nozzle), porosity, deposit z, layer h; extruding moves

    @property
    def predicted_solid_volume(self) -> float:
        """Sum over regions of predicted solid volume, mm^3."""
        return float(sum(p.solid_volume for p in self.plans))

    def summary(self) -> list[str]:
        lines = [
            f"{self.design.name}: {len(self.plans)} regions, "
            f"predicted solid volume {self.predicted_solid_volume:.0f} mm^3"
        ]
        for p in self.plans:
            extra = (
                f"H {p.nozzle_height_mm:.2f} mm, N {p.coil_density:.2f}"
                if p.method == "coil"
                else f"line pitch {p.pitch_mm:.2f} mm"
            )
            lines.append(
                f"  {p.region.name:10s} {p.method:4s} {p.region.porosity:5.1f} % -> "
                f"{p.porosity:5.1f} %, {p.n_layers} x {p.layer_mm:.2f} mm layers, {extra}"
            )
        return lines

    @property
    def extruded_e(self) -> float:
        """Total E (machine units) of the job: screw turns, mm^3 or mm of filament."""
        return self.predicted_solid_volume / self.settings.machine.mm3_per_e

    @property
    def mass_g(self) -> float:
        """Predicted mass of the printed part, g (solid volume x bulk density)."""
        return self.predicted_solid_volume * 1e-3 * self.settings.material.bulk_density_g_cm3

    def to_dict(self, gcode_path=None) -> dict:
        m = self.settings.machine
        return {
            "design": self.design.name,
            "gcode": None if gcode_path is None else str(gcode_path),
            "machine": m.name,
            "e_unit": m.extruder.e_unit,
            "mm3_per_e": m.mm3_per_e,
            "predicted_solid_volume_mm3": self.predicted_solid_volume,
            "mass_g": self.mass_g,
            "extruded_e": self.extruded_e,
            "regions": [
                {
                    "name": p.region.name,
                    "method": p.method,
                    "target_pct": p.region.porosity,
                    "predicted_pct": p.porosity,
                    "z0_mm": p.region.z0,
                    "z1_mm": p.region.z1,
                    "layers": p.n_layers,
                    "layer_mm": p.layer_mm,
                    "pitch_mm": p.pitch_mm,
                    "nozzle_height_mm": p.nozzle_height_mm,
                    "coil_density": p.coil_density,
                }
                for p in self.plans
            ],
        }

    def write(self, path) -> None:
        write_text(path, self.gcode)


def plan_region(region: Region, s: PrintSettings) -> RegionPlan:
    """Choose layer height, line pitch, nozzle height and coil density for one region.

    Each layer's lines together deposit exactly (1 - phi/100) x area x layer height of melt:
    the strand volume per mm of travel is set from the raster's real length, so curved
    outlines and pitches rounded to whole strips do not change the region's porosity.
    """
    height = region.z1 - region.z0
    solid = 1.0 - region.porosity / 100.0
    x0, x1, y0, y1 = region.shape.bounds()
    across = y1 - y0  # lines run along x; pitch tiles y exactly
    fill = solid * region.shape.area  # melt cross-section per unit layer height, mm^2
    if region.method == "bulk":
        n_layers = max(1, round(height / s.machine.bulk_layer_mm))
        layer = height / n_layers
        line_w = s.machine.nozzle_mm
        pitch = _tile(across, line_w / solid)
        pitch_x = _tile(x1 - x0, line_w / solid)
        v_x = fill * layer / _raster_length(region, pitch, 0)
        v_y = fill * layer / _raster_length(region, pitch_x, 1)
        return RegionPlan(
            region,
            "bulk",
            layer,
            n_layers,
            pitch,
            pitch_x,
            layer,
            0.0,
            v_x,
            s.machine.bulk_speed_mm_s,
            region.porosity,
            v_y,
        )
    model = s.porosity_model
    try:
        h_nozzle = model.height_for(region.porosity, s.coil_density)
        n_target = s.coil_density
    except InputError:
        # Outside the calibrated heights at this N: stay at the nearest height, change N instead.
        lo, hi = model.coil.h_min_mm, model.coil.h_max_mm
        h_nozzle = hi if region.porosity > model.porosity(hi, s.coil_density) else lo
        n_target = model.coil_density_for(region.porosity, h_nozzle)
        if not MIN_COIL_DENSITY <= n_target <= MAX_COIL_DENSITY:
            raise InputError(
                f"region {region.name!r}: porosity {region.porosity:.1f} % is out of reach of coiling "
                f"(nozzle height {lo:g}-{hi:g} mm needs a coil density of {n_target:.2f}, outside "
                f"{MIN_COIL_DENSITY:g}-{MAX_COIL_DENSITY:g})"
            ) from None
    if float(model.coil.radius(h_nozzle)) <= 0:
        raise InputError(f"region {region.name!r}: coil radius at nozzle height {h_nozzle:.2f} mm is not positive")
    n_layers = max(1, round(height / s.coil_layer_mm))
    layer = height / n_layers
    pitch = _tile(across, s.strand_area * math.pi * n_target / (solid * layer))
    # Trim N so the strand laid per mm of travel fills exactly the target solid fraction.
    volume_per_mm = fill * layer / _raster_length(region, pitch, 0)
    n_eff = volume_per_mm / (math.pi * s.strand_area)
    speed = s.machine.coil_strand_mm_s / (math.pi * n_eff)
    return RegionPlan(
        region,
        "coil",
        layer,
        n_layers,
        pitch,
        pitch,
        h_nozzle,
        n_eff,
        volume_per_mm,
        speed,
        region.porosity,
        volume_per_mm,
    )


def _raster_length(region: Region, pitch: float, axis: int) -> float:
    """Total length (mm) of the raster lines over ``region`` at ``pitch`` along ``axis``."""
    lines = _raster(region, pitch, axis, (0.0, 0.0))
    length = sum(math.hypot(xb - xa, yb - ya) for xa, ya, xb, yb in lines)
    if length <= 0:
        raise InputError(f"region {region.name!r} is too small for a {pitch:.2f} mm line pitch")
    return length


def _tile(width: float, pitch: float) -> float:
    """The pitch closest to ``pitch`` that divides ``width`` into whole strips."""
    return width / max(1, round(width / pitch))


def _raster(
    region: Region, pitch: float, axis: int, offset: tuple[float, float]
) -> list[tuple[float, float, float, float]]:
    """Serpentine lines over the region's shape, along ``axis``, one per strip of ``pitch``."""
    x0, x1, y0, y1 = region.shape.bounds()
    lo, hi = (y0, y1) if axis == 0 else (x0, x1)
    n = max(1, round((hi - lo) / pitch))
    lines = []
    for k in range(n):
        c = lo + (k + 0.5) * (hi - lo) / n
        spans = [sp for sp in region.shape.spans(axis, c) if sp[1] - sp[0] >= 1e-6]
        if k % 2:
            spans = [(b, a) for a, b in reversed(spans)]
        for a, b in spans:
            if axis == 0:
                lines.append((a + offset[0], c + offset[1], b + offset[0], c + offset[1]))
            else:
                lines.append((c + offset[0], a + offset[1], c + offset[0], b + offset[1]))
    return lines


def generate(design: Design, settings: PrintSettings | None = None) -> PrintJob:
    """Plan every region of ``design`` and write its G-code (part centred on the bed)."""
    s = settings or PrintSettings()
    m = s.machine
    plans = {r.name: plan_region(r, s) for r in design.regions}
    bx0, bx1, by0, by1 = design.bounds()
    offset = (m.build_x_mm / 2 - (bx0 + bx1) / 2, m.build_y_mm / 2 - (by0 + by1) / 2)
    top = design.height + max(p.nozzle_height_mm for p in plans.values())
    # The nozzle coils up to H above the part and lifts 5 mm clear: that height must fit too.
    m.check_fits(f"design {design.name!r} (nozzle up to {top + 5.0:.0f} mm)", bx1 - bx0, by1 - by0, top + 5.0)

    # Every layer of every region, printed in order of the surface it leaves behind.
    layers = []
    for r in design.regions:
        p = plans[r.name]
        for k in range(p.n_layers):
            layers.append((r.z0 + (k + 1) * p.layer_mm, r.z0 + k * p.layer_mm, r.name, k))
    layers.sort(key=lambda item: (round(item[0], 6), item[1]))

    out = [
        f"; porosense InFoam G-code: {design.name} ({design.actuator})",
        f"; machine {m.name}: {m.description}",
        f";MACHINE name={m.name} extruder={m.extruder.kind} e_unit={m.extruder.e_unit} "
        f"mm3_per_e={m.mm3_per_e:.6g} nozzle_mm={m.nozzle_mm:g} build={m.build_x_mm:g}x{m.build_y_mm:g}x{m.build_z_mm:g}",
        f"; material {s.material.name}, hotend {m.hotend_c:g} C, bed {m.bed_c:g} C",
        f"; porosity model: solid = {s.porosity_model.c_mm:.4f} N / (2 Rc + d + {s.porosity_model.e_mm:.4f}), "
        f"Rc = {s.porosity_model.coil.a:g} H + {s.porosity_model.coil.b:g}",
        "G21 ; mm",
        "G90 ; absolute positions",
        "M83 ; relative extrusion",
    ]
    if m.extruder.e_unit == "turn" and m.extruder.steps_per_turn > 0:
        out.append(f"M92 E{m.extruder.steps_per_turn:g} ; E counts screw turns")
    out += [
        f"M140 S{m.bed_c:g}",
        f"M104 S{m.hotend_c:g}",
        "G28 ; home",
        f"M190 S{m.bed_c:g}",
        f"M109 S{m.hotend_c:g}",
    ]
    for p in plans.values():
        r = p.region
        out.append(
            f";REGION name={r.name} method={p.method} target={r.porosity:.2f} predicted={p.porosity:.2f} "
            f"z0={r.z0:.3f} z1={r.z1:.3f} volume={r.volume:.3f}"
        )
    segments = []
    printed_top = 0.0
    e_per_vol = 1.0 / m.mm3_per_e
    for z_top, z_bottom, name, k in layers:
        p = plans[name]
        z_nozzle = z_bottom + p.nozzle_height_mm
        # Coils are laid along x only; conventional layers alternate x and y.
        axis = k % 2 if p.method == "bulk" else 0
        lines = _raster(p.region, p.pitch_mm if axis == 0 else p.pitch_x_mm, axis, offset)
        if not lines:
            continue
        safe = max(printed_top, z_nozzle) + 1.0
        out.append(f";LAYER region={name} index={k} z={z_bottom:.3f} h={p.layer_mm:.4f} nozzle_z={z_nozzle:.3f}")
        out.append(f"G0 Z{safe:.3f} F{m.travel_speed_mm_s * 60:.0f}")
        out.append(f"G0 X{lines[0][0]:.3f} Y{lines[0][1]:.3f} F{m.travel_speed_mm_s * 60:.0f}")
        out.append(f"G1 Z{z_nozzle:.3f} F{m.travel_speed_mm_s * 60:.0f}")
        prev = None
        for xa, ya, xb, yb in lines:
            if prev is not None:
                out.append(f"G0 X{xa:.3f} Y{ya:.3f}")
            length = math.hypot(xb - xa, yb - ya)
            e = length * p.volume_per_mm_along(axis) * e_per_vol
            out.append(f"G1 X{xb:.3f} Y{yb:.3f} E{e:.5f} F{p.speed_mm_s * 60:.0f}")
            segments.append(
                (xa, ya, z_nozzle, xb, yb, z_nozzle, p.region.porosity, z_bottom + p.layer_mm / 2, p.layer_mm)
            )
            prev = (xb, yb)
        printed_top = max(printed_top, z_top)
    out += [
        f"G0 Z{min(m.build_z_mm, top + 10.0):.3f}",
        "M104 S0",
        "M140 S0",
        "M84",
    ]
    return PrintJob(design, s, list(plans.values()), "\n".join(out) + "\n", np.array(segments, dtype=float))
