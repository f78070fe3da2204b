"""Rendered scenes shared by the record tests (rendering takes ~10 s per video)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import render  # noqa: E402


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    """One rendered video (seed 11) with its board recording and layout written to files."""
    tmp = tmp_path_factory.mktemp("scene")
    sc = render.render(tmp / "scene.avi", seed=11)
    sc.board.to_csv(tmp / "board.csv")
    (tmp / "layout.json").write_text(json.dumps(sc.layout), encoding="utf-8")
    return sc
