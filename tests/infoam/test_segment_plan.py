"""The 3-DoF segment as a print plan: three 76 % contractors on a 52 mm triangle, and frames."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from porosense.cli import main
from porosense.infoam import read_gcode


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    out = tmp_path_factory.mktemp("segment")
    assert main(["infoam", "plan", "segment", "--out", str(out)]) == 0
    return out, json.loads((out / "plan.json").read_text())


def test_plan_lists_the_contractors_and_their_frames(plan):
    out, d = plan
    items = {i["name"]: i for i in d["items"]}
    assert items["paper_segment"]["kind"] == "print" and items["paper_segment"]["machine"] == "pellet-ender5plus"
    assert items["segment_base"]["material"] == items["segment_stage"]["material"] == "pla"
    for i in d["items"]:
        if i["file"]:
            assert (out / i["file"]).stat().st_size > 1000
    sleeves = [i for i in d["items"] if i["name"].startswith("SEBS sleeve")]
    assert sleeves and sleeves[0]["count"] == 3


def test_three_contractors_76_percent_on_a_52_mm_triangle(plan):
    out, _ = plan
    g = read_gcode(out / "segment.gcode")
    centres = []
    for k in (1, 2, 3):
        regions = [r for r in g.regions if r.startswith(f"c{k}_")]
        assert len(regions) == 9
        s = np.vstack([np.array(g.segments_by_region[r]) for r in regions])
        xs, ys = np.concatenate([s[:, 0], s[:, 2]]), np.concatenate([s[:, 1], s[:, 3]])
        centres.append(((xs.min() + xs.max()) / 2, (ys.min() + ys.max()) / 2))
        assert 24.0 <= np.ptp(xs) <= 25.0 and 24.0 <= np.ptp(ys) <= 25.0
        for r in regions:
            if "foam" in r or "core" in r:
                phi = g.region_porosity(r)
                assert abs(phi - 76.0) <= 1.0, (r, phi)
        assert max(g.region_z(r)[1] for r in regions) == pytest.approx(50.0, abs=1e-3)
    sides = [math.dist(a, b) for a, b in itertools.combinations(centres, 2)]
    print("centre distances (mm):", np.round(sides, 3))
    assert np.allclose(sides, 52.0, atol=0.3)
    # The triangle's corner at 90 deg points to +y, as in the simulator's kinematics.
    cx = np.mean([c[0] for c in centres])
    cy = np.mean([c[1] for c in centres])
    assert centres[0][1] - cy == pytest.approx(52.0 / math.sqrt(3.0), abs=0.3) and abs(centres[0][0] - cx) < 0.3
