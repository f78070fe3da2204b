"""Fixtures of the standalone tests: the firmware ELF and the simboard harness (built once),
and a small quantized WH model."""

from __future__ import annotations

import fcntl
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SIMBOARD_DIR = ROOT / "tools" / "simboard"


@pytest.fixture(scope="session")
def elf() -> Path:
    """The firmware ELF (built) and the simboard harness; skips with the reason when absent."""
    from porosense.bench import firmware as fw

    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    if not Path("/usr/include/simavr/sim_avr.h").is_file():
        pytest.skip("libsimavr-dev is not installed: no simboard")
    (SIMBOARD_DIR / "build").mkdir(exist_ok=True)
    with open(SIMBOARD_DIR / "build" / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        proc = fw.build()
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        if shutil.which("make"):
            r = subprocess.run(["make", "-s", "-C", str(SIMBOARD_DIR)], capture_output=True, text=True)
            if r.returncode != 0:
                pytest.skip(f"the simboard harness does not build: {r.stderr[-500:]}")
    from porosense.simboard import harness_path

    if not harness_path().is_file():
        pytest.skip(f"simboard harness missing at {harness_path()}")
    return fw.ELF


@pytest.fixture(scope="session")
def model_blob() -> bytes:
    """A small 3-input, 2-output WH model quantized for the firmware (fixed seed)."""
    from porosense.quant import quantize
    from porosense.quant.random_models import random_structure

    s = random_structure(np.random.default_rng(3), 3, 2, h1_poles=2, h2_poles=2, kind="wh")
    return quantize(s, input_range=(-100.0, 100.0)).blob.to_bytes()
