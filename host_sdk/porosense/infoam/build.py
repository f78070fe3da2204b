"""The whole build of an actuator: its cTPE print, its PLA fixtures and the bought parts.

``build_plan("segment", machine, folder)`` writes the 3-DoF segment's three contractors as one
G-code job for the pellet printer, the base and stage (with the BNO055 mount) as STL, a
toolpath preview, and ``plan.json`` listing every item with its material, machine, mass and
purpose. The contractor and the bending actuator get the same treatment with their holders.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from porosense.files import write_text
from porosense.infoam.design import get_design
from porosense.infoam.gcode import PrintSettings, generate
from porosense.infoam.parts import SLEEVE_MM, build_parts
from porosense.infoam.profiles import Machine

#: Fixtures (parts.PARTS names) each actuator needs.
FIXTURES = {
    "contractor": ("contractor_hanger", "contractor_load_hook"),
    "bending": ("bending_holder",),
    "segment": ("segment_base", "segment_stage"),
}
#: Bought or hand-made items (name, quantity per actuator body) every sensorised actuator needs.
SUPPLIES = (
    (f"SEBS sleeve, {SLEEVE_MM:g} mm film, heat-sealed around the body", 1),
    ("copper wire electrode, pushed 5 mm into the cTPE", 2),
    ("silicone vacuum tube, 4 mm OD", 1),
)


@dataclass(frozen=True)
class BuildItem:
    """One thing to print or buy: file (None when bought), material, machine, count, mass (g)."""

    name: str
    kind: str  # "print" (G-code), "fixture" (STL), "supply"
    material: str
    count: int
    purpose: str
    file: str | None = None
    machine: str | None = None
    mass_g: float | None = None


@dataclass
class BuildPlan:
    """Everything one actuator takes, as written to ``folder``."""

    actuator: str
    folder: str
    items: list[BuildItem] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "format": "porosense-build-plan",
            "version": 1,
            "actuator": self.actuator,
            "folder": self.folder,
            "items": [asdict(i) for i in self.items],
        }

    def summary(self) -> list[str]:
        lines = [f"{self.actuator}: {len(self.items)} items in {self.folder}"]
        for i in self.items:
            mass = f"{i.mass_g:7.1f} g" if i.mass_g is not None else " " * 9
            lines.append(f"  {i.count} x {i.name:24s} {i.kind:8s} {i.material:5s} {mass}  {i.file or ''}")
        return lines


def build_plan(actuator: str, machine: Machine, folder, fixture_machine: Machine | None = None) -> BuildPlan:
    """Write the G-code, STL fixtures, preview and plan.json of ``actuator`` into ``folder``.

    ``machine`` prints the cTPE body; ``fixture_machine`` (default: the same printer) must fit
    the PLA fixtures.
    """
    from porosense.infoam.preview import plot_toolpath

    folder = Path(folder)
    design = get_design(actuator)
    job = generate(design, PrintSettings(machine=machine))
    gcode = f"{actuator}.gcode"
    job.write(folder / gcode)
    plot_toolpath(job, folder / f"{actuator}_toolpath.png")
    bodies = 3 if actuator == "segment" else 1
    plan = BuildPlan(actuator, str(folder))
    plan.items.append(
        BuildItem(design.name, "print", machine.material, 1, design.notes, gcode, machine.name, round(job.mass_g, 2))
    )
    for part in build_parts(FIXTURES[actuator], fixture_machine or machine):
        row = part.write(folder)
        plan.items.append(
            BuildItem(
                part.name,
                "fixture",
                "pla",
                1,
                part.purpose,
                row["file"],
                (fixture_machine or machine).name,
                round(row["mass_g"], 2),
            )
        )
    for name, n in SUPPLIES:
        plan.items.append(BuildItem(name.split(",")[0], "supply", "-", n * bodies, name))
    write_text(folder / "plan.json", json.dumps(plan.to_dict(), indent=2) + "\n")
    return plan
