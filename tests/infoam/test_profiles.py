"""Machine profiles are data files, and every wrong one is refused with one clear line."""

from __future__ import annotations

import json
import re
import tomllib
from dataclasses import replace
from importlib import resources

import pytest

from porosense.cli import main
from porosense.errors import InputError
from porosense.infoam import (
    CoilRadiusFit,
    PrintSettings,
    generate,
    list_machines,
    load_machine,
    paper_bending,
    paper_contractor,
    read_gcode,
)

PROFILES = resources.files("porosense.infoam") / "profile_data"


def _text(name):
    return (PROFILES / f"{name}.toml").read_text()


def test_builtin_profiles_load_with_the_paper_printer_as_default():
    assert set(list_machines()) >= {"pellet-ender5plus", "filament-ender5plus", "filament-generic"}
    m = load_machine()
    assert m.name == "pellet-ender5plus"
    assert (m.build_x_mm, m.build_y_mm, m.build_z_mm) == (350.0, 350.0, 400.0)
    assert m.extruder.kind == "pellet-screw" and m.extruder.e_unit == "turn"
    f = load_machine("filament-generic")
    assert f.extruder.filament_diameter_mm == 1.75 and f.mm3_per_e == pytest.approx(3.14159 * 1.75**2 / 4, rel=1e-4)


def test_same_part_same_melt_on_every_machine_whatever_its_e_unit():
    """E differs by unit; E x (mm^3 per E) is the same melt on every profile."""
    volumes = {}
    for name in ("pellet-ender5plus", "filament-ender5plus", "filament-generic"):
        m = load_machine(name)
        g = read_gcode(generate(paper_contractor(), PrintSettings(machine=m)).gcode)
        data = tomllib.loads(_text(name))["extruder"]
        per_e = (
            data["mm3_per_turn"]
            if data["e_unit"] == "turn"
            else 3.141592653589793 * data["filament_diameter_mm"] ** 2 / 4
        )
        volumes[name] = g.extruded_mm * per_e
    print({k: round(v) for k, v in volumes.items()})
    ref = volumes["pellet-ender5plus"]
    assert all(abs(v / ref - 1) < 1e-3 for v in volumes.values())


def _bad(tmp_path, name, old, new, base="pellet-ender5plus"):
    text = _text(base)
    assert re.search(old, text, flags=re.M), old
    path = tmp_path / f"{name}.toml"
    path.write_text(re.sub(old, new, text, count=1, flags=re.M))
    return path


@pytest.mark.parametrize(
    "case, old, new, message",
    [
        ("negative_bed", r"^x_mm = .*$", "x_mm = -350.0", r"build_x_mm must be a positive"),
        ("zero_nozzle", r"^diameter_mm = .*$", "diameter_mm = 0.0", r"nozzle_mm must be a positive"),
        ("zero_layer", r"^bulk_layer_mm = .*$", "bulk_layer_mm = 0", r"bulk_layer_mm must be a positive"),
        ("hot", r"^hotend_c = .*$", "hotend_c = 250.0", r"hotend 250 C outside the ctpe range 180-230 C"),
        ("cold", r"^hotend_c = .*$", "hotend_c = 150.0", r"hotend 150 C outside the ctpe range"),
        ("above_heater", r"^hotend_c = .*$", "hotend_c = 270.0", r"above its limit 260 C"),
        ("screw_constant", r"^mm3_per_turn = .*$", "mm3_per_turn = -2.0", r"mm3_per_turn must be a positive"),
        ("unit", r"^e_unit = .*$", 'e_unit = "inch"', r"e_unit 'inch' is not one of"),
        ("typo", r"^z_mm = .*$", "zz_mm = 400.0", r"\[build\] has unknown key\(s\) zz_mm"),
        ("text", r"^y_mm = .*$", 'y_mm = "wide"', r"\[build\] y_mm must be a number"),
        ("toml", r"^\[speeds\].*$", "[speeds", r"not valid TOML"),
    ],
)
def test_bad_profile_is_refused_with_one_line(tmp_path, capsys, case, old, new, message):
    path = _bad(tmp_path, case, old, new)
    with pytest.raises(InputError, match=message):
        load_machine(str(path))
    # The CLI: exit 2, one line on stderr naming the file, no traceback, no G-code written.
    out = tmp_path / "x.gcode"
    assert main(["infoam", "gcode", "contractor", "--machine", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "Traceback" not in err[0], err
    assert not out.exists()


def test_part_larger_than_the_bed_is_refused(tmp_path, capsys):
    small = replace(load_machine(), build_x_mm=60.0)
    with pytest.raises(InputError, match=r"paper_bending.*larger than the pellet-ender5plus build volume 60 x 350"):
        generate(paper_bending(), PrintSettings(machine=small))
    tall = replace(load_machine(), build_z_mm=50.0)  # the part is 50 mm, the coiling nozzle goes higher
    with pytest.raises(InputError, match="larger than"):
        generate(paper_contractor(), PrintSettings(machine=tall))
    # Fixtures: the 3-DoF base (about 120 mm across) on a 100 mm bed.
    path = _bad(tmp_path, "small", r"^x_mm = .*$", "x_mm = 100.0", base="filament-generic")
    assert main(["infoam", "parts", "--out", str(tmp_path / "p"), "--machine", str(path)]) == 2
    err = capsys.readouterr().err
    assert "part segment_base" in err and "larger than" in err


def test_unknown_machine_and_material_mismatch(tmp_path):
    with pytest.raises(InputError, match="unknown machine 'ender9'"):
        load_machine("ender9")
    with pytest.raises(InputError, match="no such machine profile"):
        load_machine(str(tmp_path / "absent.toml"))
    path = _bad(tmp_path, "nylon", r"^material = .*$", 'material = "nylon"')
    with pytest.raises(InputError, match="unknown material 'nylon'"):
        load_machine(str(path))


def test_zero_or_negative_design_dimensions_are_refused(tmp_path):
    from porosense.infoam import Design

    d = paper_bending().to_dict()
    d["regions"][1]["shape"]["x1"] = d["regions"][1]["shape"]["x0"]  # zero length
    with pytest.raises(InputError, match="zero or negative size"):
        Design.from_dict(d)
    d = paper_contractor().to_dict()
    d["regions"][0]["shape"]["r"] = -12.5
    with pytest.raises(InputError, match="zero or negative size"):
        Design.from_dict(d)
    d = paper_contractor().to_dict()
    d["regions"][0]["z1"] = 0.0
    with pytest.raises(InputError, match="must be above z0"):
        Design.from_dict(d)
    with pytest.raises(InputError, match="ring height"):
        paper_contractor(ring_mm=0.0)


def test_negative_coil_radius_gives_no_gcode(tmp_path, capsys):
    """Issue 19 item 7: a calibration whose coil radius is negative used to give G-code."""
    with pytest.raises(InputError, match="coil radius must be positive|must be positive"):
        CoilRadiusFit(0.40, -2.0)  # -1.0 mm at H = 2.5 mm
    with pytest.raises(InputError, match="must grow with nozzle height"):
        CoilRadiusFit(-0.40, 5.0)
    # Measured radii that are negative are refused by the fit and by the CLI.
    csv = tmp_path / "radii.csv"
    csv.write_text("height_mm,radius_mm\n3,-0.5\n5,0.2\n8,1.4\n")
    assert main(["infoam", "calibrate", "--coil-radii", str(csv)]) == 2
    assert "must be positive" in capsys.readouterr().err
    # A calibration file edited to a negative radius: no G-code, exit 2, one line.
    cal = tmp_path / "cal.json"
    assert main(["infoam", "calibrate", "--out", str(cal)]) == 0
    capsys.readouterr()
    data = json.loads(cal.read_text())
    data["model"]["coil"]["b"] = -2.0
    cal.write_text(json.dumps(data))
    out = tmp_path / "c.gcode"
    assert main(["infoam", "gcode", "contractor", "--calibration", str(cal), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "coil radius" in err[0] and "-1.00 mm" in err[0], err
    assert not out.exists()


def test_machines_command_lists_and_checks(tmp_path, capsys):
    assert main(["infoam", "machines", "--json"]) == 0
    assert "pellet-ender5plus" in json.loads(capsys.readouterr().out)
    assert main(["infoam", "machines", "pellet-ender5plus", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["extruder"]["e_unit"] == "turn" and d["build_z_mm"] == 400.0
    bad = _bad(tmp_path, "bad", r"^z_mm = .*$", "z_mm = 0")
    assert main(["infoam", "machines", str(bad)]) == 2
