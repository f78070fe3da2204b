"""The STL fixtures: closed solids, and cups and slots that fit the sleeved actuators.

Probes decide inside/outside with the generalised winding number (the solid angle every
triangle subtends, summed over the mesh / 4 pi: 1 inside a closed solid, 0 outside), written
here independently of the mesh library. Dimensions come from the paper: contractor 25 mm in
diameter with 5 mm solid ends, bending actuator 15 mm wide and 1 + 10 mm tall, contractors on
a 52 mm triangle (the simulator's corner angles 90, 210, 330 deg), SEBS sleeve 0.4 mm, and
the BNO055 breakout's outline (26.7 x 20.3 mm).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from porosense.cli import main
from porosense.infoam.parts import PARTS, build_part

SLEEVED_R = 12.5 + 0.4  # contractor radius with its sleeve, mm
CLEARANCE_MAX = 1.0  # a cup or slot may be at most this much (mm) looser than the sleeved part
CUP_DEPTH = 5.0  # the contractor's solid end


def winding(mesh, points) -> np.ndarray:
    """Generalised winding number of ``points`` (n, 3) w.r.t. the closed triangle mesh."""
    tri = np.asarray(mesh.triangles)  # (m, 3, 3)
    out = []
    for p in np.atleast_2d(points):
        a, b, c = (tri[:, k, :] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        det = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", b, c) * la
            + np.einsum("ij,ij->i", c, a) * lb
        )
        out.append(np.sum(2.0 * np.arctan2(det, den)) / (4.0 * math.pi))
    return np.array(out)


def solid(mesh, points) -> np.ndarray:
    return winding(mesh, points) > 0.5


@pytest.fixture(scope="module")
def parts():
    return {name: build_part(name) for name in PARTS}


def corners(side=52.0):
    r = side / math.sqrt(3.0)
    return [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a))) for a in (90.0, 210.0, 330.0)]


def ring(cx, cy, r, z, n=12):
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t), np.full(n, z)])


def test_every_part_is_one_closed_solid_that_fits_an_ordinary_bed(parts):
    assert set(parts) == {
        "bending_holder",
        "contractor_hanger",
        "contractor_load_hook",
        "segment_base",
        "segment_stage",
    }
    for name, p in parts.items():
        m = p.mesh
        bodies = m.split(only_watertight=False)
        print(
            f"{name}: {p.size_mm[0]:.1f} x {p.size_mm[1]:.1f} x {p.size_mm[2]:.1f} mm, "
            f"{m.volume / 1000:.2f} cm^3, {len(m.faces)} triangles, {len(bodies)} body"
        )
        assert m.is_watertight and m.is_winding_consistent and m.volume > 0
        assert len(bodies) == 1
        assert m.bounds[0][2] == pytest.approx(0.0, abs=1e-6)  # lies on the bed
        assert max(p.size_mm[:2]) <= 220.0 and p.size_mm[2] <= 250.0


def test_winding_probe_tells_inside_from_outside():
    import trimesh

    box = trimesh.creation.box(extents=(10, 10, 10))
    assert list(solid(box, [[0, 0, 0], [4.9, 4.9, 4.9], [5.1, 0, 0], [0, 0, -6]])) == [True, True, False, False]


def _cup_checks(m, cx, cy, z_open, sign, port):
    """Cup at (cx, cy) opening at z_open towards ``sign`` (+1 up, -1 down)."""
    z_mid = z_open - sign * CUP_DEPTH / 2
    assert not solid(m, ring(cx, cy, SLEEVED_R, z_mid)).any()  # the sleeved contractor fits
    assert solid(m, ring(cx, cy, SLEEVED_R + CLEARANCE_MAX, z_mid)).all()  # ... snugly
    assert not solid(m, ring(cx, cy, 5.0, z_open - sign * (CUP_DEPTH - 0.1))).any()  # 5 mm deep
    assert solid(m, ring(cx, cy, 5.0, z_open - sign * (CUP_DEPTH + 0.3))).all()  # then the floor
    floor = z_open - sign * (CUP_DEPTH + 1.0)
    assert bool(solid(m, [[cx, cy, floor]])[0]) is not port  # vacuum port through the floor


def test_segment_base_holds_three_contractors_on_the_52_mm_triangle(parts):
    m = parts["segment_base"].mesh
    top = m.bounds[1][2]
    for cx, cy in corners():
        _cup_checks(m, cx, cy, top, +1, port=True)
    assert solid(m, [[0.0, 0.0, 1.0]])[0]  # one plate between the cups


def test_segment_stage_holds_the_tops_and_the_bno055(parts):
    m = parts["segment_stage"].mesh
    top = m.bounds[1][2]
    for cx, cy in corners():
        _cup_checks(m, cx, cy, top, +1, port=False)
    # BNO055 pocket on the bed face (the stage's top in use), centred on the segment axis.
    bx, by = 26.7 / 2, 20.3 / 2
    board = [[sx * bx, sy * by, 0.8] for sx in (-1, 1) for sy in (-1, 1)] + [[0.0, 0.0, 0.8]]
    assert not solid(m, board).any()
    around = [[-(bx + CLEARANCE_MAX), 0.0, 0.8], [0.0, by + CLEARANCE_MAX, 0.8], [0.0, -(by + CLEARANCE_MAX), 0.8]]
    assert solid(m, around).all()  # the pocket locates the board (cable notch on +x)
    assert solid(m, [[0.0, 0.0, 2.5]])[0]  # and has a floor


def test_contractor_hanger_and_load_hook(parts):
    h = parts["contractor_hanger"].mesh
    _cup_checks(h, 0.0, 0.0, h.bounds[1][2], +1, port=True)
    assert h.extents[0] >= 60.0  # an arm to hang it by
    hook = parts["contractor_load_hook"].mesh
    _cup_checks(hook, 0.0, 0.0, 0.0, -1, port=False)  # printed cup down
    top = hook.bounds[1][2]
    assert top - (CUP_DEPTH + 4.0) >= 15.0  # the hook rises above the cup's floor
    # The hook's eye is open in the middle and closed by material above it on the -x side.
    eye = top - 4.0 - 5.0
    assert not solid(hook, [[0.0, 0.0, eye]])[0]
    assert solid(hook, [[-2.0, 0.0, top - 2.0], [0.0, 0.0, eye - 7.0]]).all()


def test_bending_holder_slot_fits_the_sleeved_cross_section(parts):
    m = parts["bending_holder"].mesh
    w, h = 15.0 + 2 * 0.4, 1.0 + 10.0 + 2 * 0.4  # sleeved cross-section, mm
    z0 = 4.0 + 0.2  # the holder's 4 mm wall under the slot, plus the fit
    xs = (m.bounds[1][0] - 0.5, m.bounds[1][0] - 8.0)  # at the mouth and 8 mm deep
    inside = [[x, sy * w / 2, z] for x in xs for sy in (-1, 1) for z in (z0, z0 + h)]
    assert not solid(m, inside).any()
    loose = [[xs[1], sy * (w / 2 + CLEARANCE_MAX), z0 + h / 2] for sy in (-1, 1)]
    loose += [[xs[1], 0.0, z0 + h + CLEARANCE_MAX], [xs[1], 0.0, z0 - CLEARANCE_MAX]]
    assert solid(m, loose).all()
    assert m.bounds[1][0] - m.bounds[0][0] >= 12.0  # grips at least 8 mm behind a back wall


def test_cli_writes_the_stl_set_that_reads_back_closed(tmp_path, capsys):
    import json

    import trimesh

    assert main(["infoam", "parts", "--out", str(tmp_path / "parts"), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["file"] for r in rows} == {f"{n}.stl" for n in PARTS}
    for r in rows:
        m = trimesh.load(tmp_path / "parts" / r["file"])
        assert m.is_watertight and m.volume / 1000 == pytest.approx(r["volume_cm3"], rel=1e-4)
    assert main(["infoam", "parts", "--out", str(tmp_path / "p2"), "--only", "nope"]) == 2
