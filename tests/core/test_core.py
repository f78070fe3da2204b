"""Build firmware/lib/core for the host with ASan/UBSan and run every C++ test binary.

Each tests/core/test_*.cpp is a program that exits 0 when all its checks pass and prints
what it measured; a sanitizer finding aborts it with a non-zero status.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
SOURCES = sorted(HERE.glob("test_*.cpp"))


@pytest.fixture(scope="module")
def built() -> Path:
    if shutil.which("g++") is None:
        pytest.skip("g++ not installed")
    proc = subprocess.run(["make", "-s", "-j2", "-C", str(HERE)], capture_output=True, text=True)
    assert proc.returncode == 0, f"host build of lib/core failed:\n{proc.stdout}\n{proc.stderr}"
    return HERE / "build"


@pytest.mark.xdist_group("core-build")
@pytest.mark.parametrize("source", SOURCES, ids=[s.stem for s in SOURCES])
def test_core_program(built: Path, source: Path) -> None:
    exe = built / source.stem
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=600, cwd=HERE)
    print(proc.stdout)
    assert proc.returncode == 0, f"{source.name} failed (exit {proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
