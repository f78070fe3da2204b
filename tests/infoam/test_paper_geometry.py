"""The CLI's G-code for the paper's printer, read back, against the paper's dimensions.

Paper facts (Willemstein et al.): contractor 25 mm in diameter and 50 mm tall, 5 mm base and
top below 5 % porosity, low-porosity rings 5.6 mm wide at 14 and 28 mm; bending actuator with
a 1 mm bulk base, four 84 % sections in a 75 x 15 x 10 mm body and four spacers below 5 %;
pellet screw extruder on an Ender 5 Plus (350 x 350 x 400 mm). Envelope volumes are computed
here from those numbers and from the move coordinates; the melt volume comes from the summed
E values times the screw constant read from the profile file itself.
"""

from __future__ import annotations

import math
import tomllib
from importlib import resources

import numpy as np
import pytest

from porosense.cli import main
from porosense.infoam import read_gcode

PROFILE = tomllib.loads((resources.files("porosense.infoam") / "profile_data" / "pellet-ender5plus.toml").read_text())
MM3_PER_TURN = PROFILE["extruder"]["mm3_per_turn"]
BED_CENTRE = (350.0 / 2, 350.0 / 2)
SOLID_MAX_PCT = 5.0  # "below 5 %" / "near zero porosity"
FOAM_TOL_PCT = 1.0  # printed porosity of a foam region within 1 point of its target


def _gcode(tmp_path_factory, design):
    out = tmp_path_factory.mktemp(design) / f"{design}.gcode"
    assert main(["infoam", "gcode", design, "--machine", "pellet-ender5plus", "--out", str(out)]) == 0
    return read_gcode(out)


@pytest.fixture(scope="module")
def contractor(tmp_path_factory):
    return _gcode(tmp_path_factory, "contractor")


@pytest.fixture(scope="module")
def bending(tmp_path_factory):
    return _gcode(tmp_path_factory, "bending")


def _porosity(g, region, envelope_mm3):
    melt = g.extruded_by_region[region] * MM3_PER_TURN
    return 100.0 * (1.0 - melt / envelope_mm3)


def _seg(g, region):
    return np.array(g.segments_by_region[region])


def _radii(g, region):
    s = _seg(g, region)
    pts = np.vstack([s[:, 0:2], s[:, 2:4]]) - BED_CENTRE
    return np.hypot(pts[:, 0], pts[:, 1])


def _closest_approach(g, region):
    """Smallest distance (mm) of the region's extruding moves from the part's axis."""
    s = _seg(g, region)
    a, b = s[:, 0:2] - BED_CENTRE, s[:, 2:4] - BED_CENTRE
    d = b - a
    t = np.clip(-np.sum(a * d, axis=1) / np.maximum(np.sum(d * d, axis=1), 1e-12), 0.0, 1.0)
    return float(np.min(np.hypot(*(a + t[:, None] * d).T)))


def test_gcode_is_for_the_pellet_screw_ender5plus(contractor):
    assert contractor.machine["e_unit"] == "turn" and contractor.machine["extruder"] == "pellet-screw"
    assert contractor.e_steps == [PROFILE["extruder"]["steps_per_turn"]]
    for ax, limit in zip("XYZ", (350.0, 350.0, 400.0)):
        lo, hi = contractor.move_extents[ax]
        assert 0.0 <= lo and hi <= limit
    # Screw turns, not mm of 1.75 mm filament: a 25 x 50 mm contractor at ~76 % foam takes
    # ~11 cm^3 of melt, i.e. hundreds of turns at 24 mm^3/turn (thousands of mm as filament).
    assert 200 < contractor.extruded_mm < 1000


def test_contractor_outline_is_25_mm_by_50_mm(contractor):
    x0, x1 = contractor.extents["X"]
    y0, y1 = contractor.extents["Y"]
    assert 24.0 <= x1 - x0 <= 25.0 and 24.0 <= y1 - y0 <= 25.0
    assert abs((x0 + x1) / 2 - BED_CENTRE[0]) < 0.3 and abs((y0 + y1) / 2 - BED_CENTRE[1]) < 0.3
    assert max(np.max(_radii(contractor, r)) for r in contractor.regions) <= 12.5 + 1e-3
    top = max(contractor.region_z(r)[1] for r in contractor.regions)
    assert top == pytest.approx(50.0, abs=1e-3)


@pytest.mark.parametrize("name, z0, z1", [("base", 0.0, 5.0), ("top", 45.0, 50.0)])
def test_contractor_solid_ends_are_5_mm_and_below_5_percent(contractor, name, z0, z1):
    lo, hi = contractor.region_z(name)
    assert lo == pytest.approx(z0, abs=1e-3) and hi == pytest.approx(z1, abs=1e-3)
    # Envelope: the full disc, so the 4.2 mm tube channel through the top counts as porosity.
    phi = _porosity(contractor, name, math.pi * 12.5**2 * (z1 - z0))
    print(f"{name}: porosity {phi:.2f} %")
    assert -1.0 <= phi < SOLID_MAX_PCT
    hole = _closest_approach(contractor, name)
    assert (hole >= 2.0) is (name == "top"), hole  # the vacuum tube's port is in the top only


@pytest.mark.parametrize("z", [14.0, 28.0])
def test_contractor_rings_are_5_6_mm_wide_at_14_and_28_mm_and_near_solid(contractor, z):
    ring = f"ring_{z:g}"
    lo, hi = contractor.region_z(ring)
    assert lo == pytest.approx(z, abs=1e-3) and hi - lo == pytest.approx(5.6, abs=1e-3)
    r = _radii(contractor, ring)
    r_in, r_out = float(r.min()), float(r.max())
    assert r_out == pytest.approx(12.5, abs=0.05)  # at the rim
    assert r_in > 6.0  # a ring, not a disc: the core stays foam
    # Envelope: the annulus the moves span (inner radius from the closest line end).
    phi = _porosity(contractor, ring, math.pi * (12.5**2 - r_in**2) * 5.6)
    print(f"{ring}: wall {12.5 - r_in:.2f} mm, porosity {phi:.2f} %")
    assert -1.0 <= phi < SOLID_MAX_PCT
    # Inside the ring the foam continues at the foam porosity.
    core = f"core_{z:g}"
    assert contractor.region_z(core) == pytest.approx((lo, hi), abs=1e-3)
    assert np.max(_radii(contractor, core)) <= r_in + 0.01  # G-code keeps 3 decimals
    phi_core = _porosity(contractor, core, math.pi * r_in**2 * 5.6)
    assert abs(phi_core - 76.0) <= FOAM_TOL_PCT, phi_core


def test_contractor_foam_fills_5_to_45_mm_at_76_percent(contractor):
    foam = [r for r in contractor.regions if r.startswith("foam_")]
    spans = sorted(contractor.region_z(r) for r in foam + ["ring_14", "ring_28"])
    assert spans[0][0] == pytest.approx(5.0, abs=1e-3) and spans[-1][1] == pytest.approx(45.0, abs=1e-3)
    assert all(a[1] == pytest.approx(b[0], abs=1e-3) for a, b in zip(spans, spans[1:]))  # no gap
    for r in foam:
        lo, hi = contractor.region_z(r)
        phi = _porosity(contractor, r, math.pi * 12.5**2 * (hi - lo))
        print(f"{r}: {lo:.1f}-{hi:.1f} mm, porosity {phi:.2f} %")
        assert abs(phi - 76.0) <= FOAM_TOL_PCT


def test_bending_base_is_1_mm_bulk_under_a_75_by_15_by_10_body(bending):
    lo, hi = bending.region_z("base")
    assert (lo, hi) == pytest.approx((0.0, 1.0), abs=1e-3)
    body = [r for r in bending.regions if r != "base"]
    s = np.vstack([_seg(bending, r) for r in body])
    xs, ys = np.concatenate([s[:, 0], s[:, 2]]), np.concatenate([s[:, 1], s[:, 3]])
    assert np.ptp(xs) == pytest.approx(75.0, abs=0.01)
    assert 15.0 - 0.7 <= np.ptp(ys) <= 15.0  # lines at strip centres, strips <= 0.7 mm in the spacers
    for r in body:
        assert bending.region_z(r) == pytest.approx((1.0, 11.0), abs=1e-3)
    phi = _porosity(bending, "base", 75.0 * 15.0 * 1.0)
    assert -1.0 <= phi < SOLID_MAX_PCT


def test_bending_has_four_84_percent_sections_and_four_solid_spacers(bending):
    sections = sorted(r for r in bending.regions if r.startswith("section_"))
    spacers = sorted(r for r in bending.regions if r.startswith("spacer_"))
    assert len(sections) == 4 and len(spacers) == 4
    lengths = {}
    for r in sections + spacers:
        s = _seg(bending, r)
        x = np.concatenate([s[:, 0], s[:, 2]])
        lengths[r] = float(np.ptp(x))
        phi = _porosity(bending, r, lengths[r] * 15.0 * 10.0)
        print(f"{r}: {x.min() - BED_CENTRE[0]:6.2f}..{x.max() - BED_CENTRE[0]:6.2f} mm, porosity {phi:.2f} %")
        if r.startswith("section_"):
            assert abs(phi - 84.0) <= FOAM_TOL_PCT
        else:
            assert -1.0 <= phi < SOLID_MAX_PCT
    assert sum(lengths.values()) == pytest.approx(75.0, abs=0.01)  # they tile the body
    assert np.ptp([lengths[r] for r in sections]) < 1e-6  # four equal sections
