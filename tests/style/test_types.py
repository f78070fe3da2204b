"""Static types of the format and arithmetic packages, checked as part of the suite: mypy
(settings and the packages it covers in mypy.ini) must find no error. A failure lists them."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_mypy_finds_no_type_error():
    exe = shutil.which("mypy", path=str(Path(sys.executable).parent)) or shutil.which("mypy")
    if exe is None:
        pytest.fail("mypy is not installed: run tools/bootstrap.sh (it is pinned in host_sdk/requirements.lock)")
    proc = subprocess.run([exe, "--config-file", "mypy.ini"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, (
        f"mypy found type errors (settings: mypy.ini):\n{proc.stdout[-6000:]}{proc.stderr[-2000:]}"
    )
    assert "no issues found" in proc.stdout, proc.stdout
