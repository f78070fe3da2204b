"""Machine and material profiles: data files (TOML) checked before anything is planned.

A machine profile names its build volume, heater limits, nozzle, extruder and speeds; the
extruder sets what one E unit of the G-code means:

- ``turn``: one revolution of a pellet screw, ``mm3_per_turn`` mm^3 of melt (calibrated);
- ``mm3``: one mm^3 of melt (volumetric extrusion);
- ``mm_filament``: one mm of filament of ``filament_diameter_mm`` pulled into the hotend.

Built-in profiles live in ``profile_data/*.toml`` beside this module; any other TOML file of the
same shape can be given by path. Every problem is reported as one InputError line naming the
file and the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path

from porosense.errors import InputError

DEFAULT_MACHINE = "pellet-ender5plus"
E_UNITS = ("turn", "mm3", "mm_filament")
EXTRUDER_KINDS = ("pellet-screw", "filament")


@dataclass(frozen=True)
class Material:
    """Printing material: bulk density (g/cm^3) and usable temperature windows (deg C)."""

    key: str
    name: str
    bulk_density_g_cm3: float
    hotend_min_c: float
    hotend_max_c: float
    bed_min_c: float
    bed_max_c: float


@dataclass(frozen=True)
class Extruder:
    """What drives the melt and what one E unit stands for."""

    kind: str
    e_unit: str
    mm3_per_turn: float = 0.0
    steps_per_turn: float = 0.0
    filament_diameter_mm: float = 0.0

    @property
    def mm3_per_e(self) -> float:
        """Melt volume (mm^3) per E unit."""
        if self.e_unit == "turn":
            return self.mm3_per_turn
        if self.e_unit == "mm3":
            return 1.0
        return math.pi * self.filament_diameter_mm**2 / 4.0


@dataclass(frozen=True)
class Machine:
    """A printer: build volume (mm), heater limits and set temperatures (deg C), nozzle (mm),
    extruder, speeds (mm/s) and the conventional layer height (mm)."""

    name: str
    description: str
    material: str
    build_x_mm: float
    build_y_mm: float
    build_z_mm: float
    hotend_max_c: float
    bed_max_c: float
    nozzle_mm: float
    extruder: Extruder
    hotend_c: float
    bed_c: float
    travel_speed_mm_s: float
    bulk_speed_mm_s: float
    bulk_layer_mm: float
    #: Strand speed at the nozzle while coiling (mm of nozzle-diameter strand per second).
    coil_strand_mm_s: float

    def __post_init__(self):
        for key in (
            "build_x_mm",
            "build_y_mm",
            "build_z_mm",
            "nozzle_mm",
            "travel_speed_mm_s",
            "bulk_speed_mm_s",
            "bulk_layer_mm",
            "coil_strand_mm_s",
            "hotend_max_c",
        ):
            _positive(f"machine {self.name!r}", key, getattr(self, key))
        if self.bulk_layer_mm > self.nozzle_mm:
            raise InputError(
                f"machine {self.name!r}: bulk_layer_mm {self.bulk_layer_mm:g} is thicker than "
                f"the {self.nozzle_mm:g} mm nozzle"
            )
        if self.hotend_c > self.hotend_max_c:
            raise InputError(
                f"machine {self.name!r}: hotend {self.hotend_c:g} C above its limit {self.hotend_max_c:g} C"
            )
        if not 0.0 <= self.bed_c <= self.bed_max_c:
            raise InputError(f"machine {self.name!r}: bed {self.bed_c:g} C outside 0..{self.bed_max_c:g} C")
        e = self.extruder
        if e.kind not in EXTRUDER_KINDS:
            raise InputError(
                f"machine {self.name!r}: extruder kind {e.kind!r} is not one of {', '.join(EXTRUDER_KINDS)}"
            )
        if e.e_unit not in E_UNITS:
            raise InputError(f"machine {self.name!r}: e_unit {e.e_unit!r} is not one of {', '.join(E_UNITS)}")
        if e.e_unit == "turn":
            _positive(f"machine {self.name!r}", "extruder.mm3_per_turn", e.mm3_per_turn)
            if e.kind != "pellet-screw":
                raise InputError(f"machine {self.name!r}: e_unit 'turn' needs a pellet-screw extruder")
        if e.e_unit == "mm_filament":
            _positive(f"machine {self.name!r}", "extruder.filament_diameter_mm", e.filament_diameter_mm)
        if e.steps_per_turn < 0:
            raise InputError(f"machine {self.name!r}: extruder.steps_per_turn must not be negative")

    @property
    def mm3_per_e(self) -> float:
        """Melt volume (mm^3) per E unit of this machine's G-code."""
        return self.extruder.mm3_per_e

    def check_temperatures(self, material: Material) -> None:
        """InputError when the set temperatures fall outside ``material``'s windows."""
        if not material.hotend_min_c <= self.hotend_c <= material.hotend_max_c:
            raise InputError(
                f"machine {self.name!r}: hotend {self.hotend_c:g} C outside the {material.key} range "
                f"{material.hotend_min_c:g}-{material.hotend_max_c:g} C"
            )
        if not material.bed_min_c <= self.bed_c <= material.bed_max_c:
            raise InputError(
                f"machine {self.name!r}: bed {self.bed_c:g} C outside the {material.key} range "
                f"{material.bed_min_c:g}-{material.bed_max_c:g} C"
            )

    def check_fits(self, what: str, size_x: float, size_y: float, size_z: float) -> None:
        """InputError when a part of size_x x size_y x size_z (mm) exceeds the build volume."""
        for size in (size_x, size_y, size_z):
            if not size > 0:
                raise InputError(f"{what}: zero or negative size {size_x:g} x {size_y:g} x {size_z:g} mm")
        if size_x > self.build_x_mm or size_y > self.build_y_mm or size_z > self.build_z_mm:
            raise InputError(
                f"{what} ({size_x:.0f} x {size_y:.0f} x {size_z:.0f} mm) is larger than the {self.name} "
                f"build volume {self.build_x_mm:g} x {self.build_y_mm:g} x {self.build_z_mm:g} mm"
            )

    def to_dict(self) -> dict:
        return asdict(self)


def _positive(where: str, key: str, value) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise InputError(f"{where}: {key} must be a positive number of the right unit (got {value!r})")


def _read_toml(path: Path, what: str) -> dict:
    try:
        return tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: no such {what} file") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file") from None


def _profiles_dir():
    return resources.files("porosense.infoam") / "profile_data"


def list_machines() -> list[str]:
    """Names of the built-in machine profiles."""
    return sorted(
        p.name[:-5] for p in _profiles_dir().iterdir() if p.name.endswith(".toml") and p.name != "materials.toml"
    )


_MATERIAL_KEYS = ("name", "bulk_density_g_cm3", "hotend_min_c", "hotend_max_c", "bed_min_c", "bed_max_c")


def load_material(key: str) -> Material:
    """A material of the built-in table (ctpe, pla) by key."""
    path = Path(str(_profiles_dir() / "materials.toml"))
    table = _read_toml(path, "materials")
    if key not in table:
        raise InputError(f"unknown material {key!r}: known are {', '.join(sorted(table))}")
    d = table[key]
    missing = [k for k in _MATERIAL_KEYS if k not in d]
    if missing:
        raise InputError(f"{path}: material {key!r} lacks {', '.join(missing)}")
    _positive(f"material {key!r}", "bulk_density_g_cm3", d["bulk_density_g_cm3"])
    if not (d["hotend_min_c"] < d["hotend_max_c"] and d["bed_min_c"] <= d["bed_max_c"]):
        raise InputError(f"{path}: material {key!r} has an empty temperature window")
    return Material(key, **{k: d[k] for k in _MATERIAL_KEYS})


#: Sections and keys of a machine profile, and the Machine field each one fills.
_MACHINE_KEYS = {
    "build": {"x_mm": "build_x_mm", "y_mm": "build_y_mm", "z_mm": "build_z_mm"},
    "limits": {"hotend_max_c": "hotend_max_c", "bed_max_c": "bed_max_c"},
    "nozzle": {"diameter_mm": "nozzle_mm"},
    "temperatures": {"hotend_c": "hotend_c", "bed_c": "bed_c"},
    "speeds": {
        "travel_mm_s": "travel_speed_mm_s",
        "bulk_mm_s": "bulk_speed_mm_s",
        "bulk_layer_mm": "bulk_layer_mm",
        "coil_strand_mm_s": "coil_strand_mm_s",
    },
}
_EXTRUDER_KEYS = {"kind", "e_unit", "mm3_per_turn", "steps_per_turn", "filament_diameter_mm"}


def machine_from_dict(d: dict, source: str) -> Machine:
    """Build and validate a Machine from a parsed profile; InputError names ``source`` and the key."""
    unknown = set(d) - {"name", "description", "material", "extruder", *_MACHINE_KEYS}
    if unknown:
        raise InputError(f"{source}: unknown key(s) {', '.join(sorted(unknown))}")
    fields: dict = {
        "name": d.get("name", Path(source).stem),
        "description": d.get("description", ""),
        "material": d.get("material", "ctpe"),
    }
    for section, keys in _MACHINE_KEYS.items():
        sec = d.get(section)
        if not isinstance(sec, dict):
            raise InputError(f"{source}: missing section [{section}]")
        extra = set(sec) - set(keys)
        if extra:
            raise InputError(f"{source}: [{section}] has unknown key(s) {', '.join(sorted(extra))}")
        for key, field_name in keys.items():
            if key not in sec:
                raise InputError(f"{source}: [{section}] lacks {key}")
            value = sec[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"{source}: [{section}] {key} must be a number (got {value!r})")
            fields[field_name] = float(value)
    ext = d.get("extruder")
    if not isinstance(ext, dict) or "kind" not in ext or "e_unit" not in ext:
        raise InputError(f"{source}: [extruder] needs kind and e_unit")
    extra = set(ext) - _EXTRUDER_KEYS
    if extra:
        raise InputError(f"{source}: [extruder] has unknown key(s) {', '.join(sorted(extra))}")
    try:
        fields["extruder"] = Extruder(**{k: (v if k in ("kind", "e_unit") else float(v)) for k, v in ext.items()})
    except (TypeError, ValueError) as exc:
        raise InputError(f"{source}: [extruder] {exc}") from None
    try:
        machine = Machine(**fields)
        machine.check_temperatures(load_material(machine.material))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    return machine


def load_machine(spec: str = DEFAULT_MACHINE) -> Machine:
    """A built-in machine profile by name, or a profile TOML file by path."""
    builtin = {name: name for name in list_machines()}
    if spec in builtin:
        path = Path(str(_profiles_dir() / f"{spec}.toml"))
    elif spec.endswith(".toml") or Path(spec).exists():
        path = Path(spec)
    else:
        raise InputError(f"unknown machine {spec!r}: give a profile TOML or one of {', '.join(builtin)}")
    return machine_from_dict(_read_toml(path, "machine profile"), str(path))
