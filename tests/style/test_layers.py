"""The package's import floors, checked as part of the suite: `lint-imports` (import-linter,
settings in .importlinter) keeps every import running downwards through the floors of TEAM.md,
keeps identification, simulation, quantization and diagnosis away from boards and the CLI, and
allows no circle between the modules of one package. A failure prints the offending chains."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_imports_follow_the_floors_without_circles():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    if exe is None:
        pytest.fail(
            "import-linter is not installed: run tools/bootstrap.sh (it is pinned in host_sdk/requirements.lock)"
        )
    proc = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    report = proc.stdout[proc.stdout.find("Contracts") :]
    assert proc.returncode == 0, (
        f"import contracts broken (settings: .importlinter):\n{report[-6000:]}{proc.stderr[-2000:]}"
    )
    assert report.count("KEPT") >= 3, report
