"""Print planning: calibration against the paper, G-code read back, prediction."""

from __future__ import annotations

import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.errors import InputError
from porosense.infoam import (
    CoilRadiusFit,
    Design,
    PorosityModel,
    PrintSettings,
    generate,
    paper_bending,
    paper_calibration,
    paper_contractor,
    porosity_from_mass,
    read_gcode,
)
from porosense.infoam.calibration import PAPER_HEIGHTS_MM, PAPER_POROSITIES_PCT


def test_calibration_reproduces_paper_porosities_within_2_points():
    model = paper_calibration()
    err = np.abs(model.porosity(PAPER_HEIGHTS_MM, 3.0) - np.array(PAPER_POROSITIES_PCT))
    print("porosity error per height (points):", np.round(err, 2))
    assert err.max() <= 2.0


def test_coil_radius_fit_recovers_a_and_b_from_synthetic_measurements():
    rng = np.random.default_rng(11)
    for _ in range(5):
        a, b = rng.uniform(0.3, 0.5), rng.uniform(-0.6, 0.1)
        h = rng.uniform(2.5, 10.0, 24)
        r = a * h + b + rng.normal(0, 0.05, h.size)  # 0.05 mm caliper noise
        fit = CoilRadiusFit.fit(h, r)
        assert abs(fit.a - a) < 0.02 and abs(fit.b - b) < 0.1, (a, b, fit)
        assert fit.r2 > 0.98


def test_porosity_model_fit_predicts_unseen_cubes_from_weighed_samples():
    rng = np.random.default_rng(5)
    true = PorosityModel(c_mm=rng.uniform(0.35, 0.5), e_mm=rng.uniform(0.3, 1.2))
    heights = np.array([3.0, 4.5, 6.0, 7.5, 9.0])
    volume = 20.0**3  # 20 mm cubes
    phi_true = true.porosity(heights, 3.0)
    mass = (1 - phi_true / 100) * volume * 1e-3 * 0.97 * (1 + rng.normal(0, 0.01, heights.size))
    phi_meas = [porosity_from_mass(m, volume) for m in mass]
    fit = PorosityModel.fit(heights, phi_meas, 3.0)
    unseen = np.array([3.5, 5.0, 8.5])
    err = np.abs(fit.porosity(unseen, 3.0) - true.porosity(unseen, 3.0))
    assert err.max() < 1.0, err


def test_porosity_from_mass_and_its_errors():
    # 1 cm^3 cube of 0.2425 g at rho_b 0.97 -> 75 % porosity
    assert porosity_from_mass(0.2425, 1000.0) == pytest.approx(75.0)
    with pytest.raises(InputError):
        porosity_from_mass(-1.0, 1000.0)
    with pytest.raises(InputError, match="denser"):
        porosity_from_mass(2.0, 1000.0)


@pytest.fixture(scope="module")
def contractor_job():
    return generate(paper_contractor())


def test_contractor_gcode_extents_and_temperatures(contractor_job):
    g = read_gcode(contractor_job.gcode)
    x0, x1 = g.extents["X"]
    y0, y1 = g.extents["Y"]
    assert 24.0 <= x1 - x0 <= 25.0 and 24.0 <= y1 - y0 <= 25.0  # 25 mm diameter, lines at strip centres
    assert abs((x0 + x1) / 2 - 175.0) < 0.5  # centred on the Ender 5 Plus's 350 mm bed
    m = contractor_job.settings.machine
    for ax, limit in (("X", m.build_x_mm), ("Y", m.build_y_mm), ("Z", m.build_z_mm)):
        lo, hi = g.move_extents[ax]
        assert 0.0 <= lo and hi <= limit
    assert set(g.hotend_temps) == {200.0, 0.0} and 60.0 in g.bed_temps


def test_contractor_layer_heights_per_region(contractor_job):
    g = read_gcode(contractor_job.gcode)
    coil_layer = contractor_job.settings.coil_layer_mm
    for region in paper_contractor().regions:
        hs = np.array(g.layer_heights[region.name])
        assert hs.sum() == pytest.approx(region.z1 - region.z0, abs=1e-3)
        if region.method == "bulk":
            assert np.all(np.abs(hs - 0.3) < 0.05)
        else:
            assert np.all(np.abs(hs - coil_layer) < 0.2 * coil_layer)
        zs = np.array(g.layer_z[region.name])
        assert zs.min() == pytest.approx(region.z0, abs=1e-3)


@pytest.mark.parametrize("make", [paper_contractor, paper_bending], ids=["contractor", "bending"])
def test_extruded_volume_matches_predicted_porosity_within_5_percent(make):
    design = make()
    job = generate(design)
    g = read_gcode(job.gcode)
    total = g.extruded_volume()  # E (screw turns) x the ;MACHINE mm^3 per turn
    ratio = total / job.predicted_solid_volume
    print(f"{design.name}: extruded {total:.0f} mm^3, predicted solid {job.predicted_solid_volume:.0f} mm^3")
    assert abs(ratio - 1) <= 0.05
    for plan in job.plans:
        r = g.extruded_volume(region=plan.region.name) / plan.solid_volume
        assert abs(r - 1) <= 0.10, (plan.region.name, r)


def test_porosity_beyond_nominal_heights_trims_coil_density():
    job = generate(paper_contractor(86.0))
    foam = [p for p in job.plans if p.method == "coil"]
    assert all(p.nozzle_height_mm == pytest.approx(10.0) and p.coil_density < 3.0 for p in foam)
    assert all(p.porosity == pytest.approx(86.0) for p in foam)


def test_higher_porosity_design_extrudes_less():
    v = [read_gcode(generate(paper_contractor(p)).gcode).extruded_volume() for p in (68.0, 76.0, 86.0)]
    assert v[0] > v[1] > v[2]


def test_unprintable_porosity_and_oversized_design_are_refused():
    with pytest.raises(InputError, match="out of reach of coiling"):
        generate(paper_contractor(97.0))
    with pytest.raises(InputError, match="larger than the .* build volume"):
        from dataclasses import replace

        from porosense.infoam import load_machine

        generate(paper_bending(), PrintSettings(machine=replace(load_machine(), build_x_mm=60.0)))


def test_design_round_trip_and_malformed_file(tmp_path):
    d = paper_bending()
    path = d.save(tmp_path / "bend.json")
    back = Design.load(path)
    assert back.to_dict() == d.to_dict()
    bad = tmp_path / "bad.json"
    bad.write_text('{"name": "x",\n "regions": [}\n')
    with pytest.raises(InputError, match=r"bad.json: line 2, column"):
        Design.load(bad)


def test_cli_writes_gcode_and_preview(tmp_path, capsys):
    out, png = tmp_path / "c.gcode", tmp_path / "c.png"
    assert main(["infoam", "gcode", "contractor", "--out", str(out), "--preview", str(png), "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in plan["regions"]} >= {"base", "foam_1", "ring_14", "core_14", "top"}
    assert plan["machine"] == "pellet-ender5plus" and plan["e_unit"] == "turn"
    assert png.stat().st_size > 10_000
    assert read_gcode(out).n_moves > 500
    assert main(["infoam", "gcode", "nope", "--out", str(out)]) == 2


def test_prediction_follows_porosity():
    from porosense.infoam import predict

    low = predict(paper_contractor(68.0))
    high = predict(paper_contractor(86.0))
    s_low, s_high = low.rows[-1].strain_pct, high.rows[-1].strain_pct
    d_low, d_high = low.rows[-1].dR_pct, high.rows[-1].dR_pct
    print(f"-60 kPa: strain {s_low:.1f} -> {s_high:.1f} %, dR {d_low:.1f} -> {d_high:.1f} %")
    assert s_high > s_low > 0 and d_high < d_low < 0
    # Stroke grows with vacuum for one design.
    strains = [r.strain_pct for r in high.rows]
    assert all(np.diff(strains) > 0)


def test_bending_prediction_reports_curvature_growing_with_vacuum():
    from porosense.infoam import predict

    pred = predict(paper_bending())
    k = [r.curvature_1pm for r in pred.rows]
    assert all(v is not None for v in k) and all(np.diff(k) > 0)
