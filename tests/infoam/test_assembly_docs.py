"""docs/assembly.md: its figures exist, are drawn by 'infoam figures', and its numbers match the parts."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from porosense.cli import main

DOCS = Path(__file__).resolve().parents[2] / "docs"
GUIDE = DOCS / "assembly.md"


def _figures():
    return re.findall(r"!\[[^\]]*\]\((figures/[^)]+\.png)\)", GUIDE.read_text())


def test_guide_exists_and_every_figure_it_shows_is_committed():
    figs = _figures()
    assert len(figs) >= 8
    for f in figs:
        path = DOCS / f
        assert path.exists(), f
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000, f


def test_guide_covers_sleeve_electrodes_wiring_and_markers():
    text = GUIDE.read_text().lower()
    for topic in (
        "0.4 mm sebs",
        "heat-seal",
        "top-left and bottom-right",
        "1 kω bias",
        "markers",
        "stripe",
        "bno055",
        "pellet",
        "350 x 350 x 400",
    ):
        assert topic in text, topic


def test_guide_dimensions_match_the_generated_parts():
    from porosense.infoam.parts import bending_slot, cup_inner_diameter

    text = GUIDE.read_text()
    w, h = bending_slot()
    assert f"{w:.1f} x {h:.1f} mm" in text
    assert f"Ø {cup_inner_diameter():.1f} x 5 mm" in text


@pytest.mark.slow
def test_figures_command_draws_every_figure_the_guide_shows(tmp_path):
    assert main(["infoam", "figures", "--out", str(tmp_path)]) == 0
    drawn = {p.name for p in tmp_path.glob("*.png")}
    shown = {Path(f).name for f in _figures()}
    assert shown <= drawn, shown - drawn
    assert all((tmp_path / n).stat().st_size > 20_000 for n in shown)
