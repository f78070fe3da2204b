"""A small G-code reader: enough to check what the planner wrote.

Understands G0/G1 (X Y Z E F), G90/G91, M82/M83, G92 E, temperature commands
(M104/M109 hotend, M140/M190 bed), M92 E, and the planner's ``;MACHINE``, ``;REGION`` and
``;LAYER`` comments. Lengths in mm; extrusion in the file's E unit, turned into melt volume
with the ``;MACHINE mm3_per_e`` conversion (or a filament diameter for foreign files).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from porosense.errors import InputError


@dataclass
class GcodeSummary:
    """What a G-code file does: extents of extruding moves, extrusion totals, temperatures."""

    extents: dict[str, tuple[float, float]] = field(default_factory=dict)  # axis -> (min, max), extruding moves
    move_extents: dict[str, tuple[float, float]] = field(default_factory=dict)  # every move
    extruded_mm: float = 0.0  # feedstock filament length
    extruded_by_region: dict[str, float] = field(default_factory=lambda: defaultdict(float))
    layer_heights: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    layer_z: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    regions: dict[str, dict[str, str]] = field(default_factory=dict)  # ;REGION key=value fields
    hotend_temps: list[float] = field(default_factory=list)
    bed_temps: list[float] = field(default_factory=list)
    n_moves: int = 0
    machine: dict[str, str] = field(default_factory=dict)  # ;MACHINE key=value fields
    e_steps: list[float] = field(default_factory=list)  # M92 E values
    #: region -> (n, 5) rows x0 y0 x1 y1 z of its extruding moves (nozzle positions, mm)
    segments_by_region: dict[str, list] = field(default_factory=lambda: defaultdict(list))

    def extruded_volume(self, filament_diameter_mm: float | None = None, region: str | None = None) -> float:
        """Extruded melt volume in mm^3 (of one region, or all).

        Uses the file's ``;MACHINE mm3_per_e``; ``filament_diameter_mm`` (mm) reads E as mm
        of filament instead (for files without that comment).
        """
        length = self.extruded_mm if region is None else self.extruded_by_region.get(region, 0.0)
        if filament_diameter_mm is not None:
            return length * math.pi * filament_diameter_mm**2 / 4.0
        if "mm3_per_e" not in self.machine:
            raise InputError("the G-code states no ;MACHINE mm3_per_e: give the filament diameter")
        return length * float(self.machine["mm3_per_e"])

    def region_z(self, region: str) -> tuple[float, float]:
        """Lowest layer bottom and highest layer top (mm) of ``region``, from its ;LAYER comments."""
        zs, hs = self.layer_z.get(region), self.layer_heights.get(region)
        if not zs:
            raise InputError(f"no layers of region {region!r} in the G-code")
        return min(zs), max(z + h for z, h in zip(zs, hs))

    def region_porosity(self, region: str) -> float:
        """Porosity (%) the extrusion gives the region's envelope (;REGION volume, mm^3)."""
        volume = float(self.regions[region]["volume"])
        return 100.0 * (1.0 - self.extruded_volume(region=region) / volume)


def read_gcode(path_or_text, *, source: str | None = None) -> GcodeSummary:
    """Read G-code from a path or a string and summarise it; InputError names a bad line."""
    if isinstance(path_or_text, Path) or (isinstance(path_or_text, str) and "\n" not in path_or_text):
        path = Path(path_or_text)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise InputError(f"{path}: no such G-code file") from None
        source = source or str(path)
    else:
        text = path_or_text
        source = source or "<gcode>"
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    absolute, abs_e = True, True
    e_pos = 0.0
    out = GcodeSummary()
    region = None
    lo: dict[str, float] = {}
    hi: dict[str, float] = {}
    mlo: dict[str, float] = {}
    mhi: dict[str, float] = {}
    for n, raw in enumerate(text.splitlines(), start=1):
        code, _, comment = raw.partition(";")
        comment = comment.strip()
        if comment.startswith(("REGION ", "LAYER ", "MACHINE ")):
            kind, _, rest = comment.partition(" ")
            fields = dict(item.split("=", 1) for item in rest.split() if "=" in item)
            if kind == "MACHINE":
                out.machine = fields
            elif kind == "REGION":
                out.regions[fields["name"]] = fields
            else:
                region = fields.get("region")
                out.layer_heights[region].append(float(fields["h"]))
                out.layer_z[region].append(float(fields["z"]))
        words = code.split()
        if not words:
            continue
        cmd = words[0].upper()
        try:
            args = {w[0].upper(): float(w[1:]) for w in words[1:]}
        except (ValueError, IndexError):
            raise InputError(f"{source}: line {n}: cannot read {code.strip()!r}") from None
        if cmd in ("G0", "G1"):
            out.n_moves += 1
            new = dict(pos)
            for ax in "XYZ":
                if ax in args:
                    new[ax] = args[ax] if absolute else pos[ax] + args[ax]
            de = 0.0
            if "E" in args:
                de = args["E"] - e_pos if abs_e else args["E"]
                e_pos = args["E"] if abs_e else e_pos + args["E"]
            for ax in "XYZ":
                for v in (pos[ax], new[ax]):
                    mlo[ax] = min(mlo.get(ax, v), v)
                    mhi[ax] = max(mhi.get(ax, v), v)
            if de > 0 and any(new[a] != pos[a] for a in "XY"):
                out.extruded_mm += de
                if region is not None:
                    out.extruded_by_region[region] += de
                    out.segments_by_region[region].append((pos["X"], pos["Y"], new["X"], new["Y"], new["Z"]))
                for ax in "XYZ":
                    for v in (pos[ax], new[ax]):
                        lo[ax] = min(lo.get(ax, v), v)
                        hi[ax] = max(hi.get(ax, v), v)
            pos = new
        elif cmd == "G90":
            absolute = True
        elif cmd == "G91":
            absolute = False
        elif cmd == "M82":
            abs_e = True
        elif cmd == "M83":
            abs_e = False
        elif cmd == "M92" and "E" in args:
            out.e_steps.append(args["E"])
        elif cmd == "G92":
            if "E" in args:
                e_pos = args["E"]
        elif cmd in ("M104", "M109") and "S" in args:
            out.hotend_temps.append(args["S"])
        elif cmd in ("M140", "M190") and "S" in args:
            out.bed_temps.append(args["S"])
    out.extents = {ax: (lo[ax], hi[ax]) for ax in lo}
    out.move_extents = {ax: (mlo[ax], mhi[ax]) for ax in mlo}
    return out
