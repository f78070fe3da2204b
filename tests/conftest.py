"""Shared fixtures: paths, the measured benchmark data, CI sizing."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _keep_freed_memory() -> None:
    """The allocator settings of porosense.dsp.heap (fits and diagnoses set them themselves) for
    everything the tests run, set here for this process and, through the environment, for the
    processes the tests start (xdist workers, the CLI, make demo): 12 simulator diagnosis trials
    spent 2.1 s of system time in page faults with 11.5 s of user time without them (0.01 s with
    them, the same user time and peak memory). A C library other than glibc ignores both."""
    from porosense.dsp.heap import MMAP_THRESHOLD_BYTES, TRIM_THRESHOLD_BYTES, keep_freed_memory

    os.environ.setdefault("MALLOC_MMAP_THRESHOLD_", str(MMAP_THRESHOLD_BYTES))
    os.environ.setdefault("MALLOC_TRIM_THRESHOLD_", str(TRIM_THRESHOLD_BYTES))
    keep_freed_memory()


_keep_freed_memory()


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The measured benchmark folder (POROSENSE_SHARED_DATA, else <repo>/../shared/data, else
    /work/shared/data, as `porosense bench` finds it), or skip with the reason when it is absent."""
    from porosense.bench.ident import shared_data_folder

    folder = shared_data_folder()
    if folder is None:
        pytest.skip("measured benchmark data not found (POROSENSE_SHARED_DATA, ../shared/data, /work/shared/data)")
    return folder


def pytest_addoption(parser):
    parser.addoption(
        "--port",
        default=None,
        help="pyserial URL of a real board (e.g. /dev/ttyACM0): adds it to the device conformance suite",
    )


@pytest.fixture(scope="session")
def simboard_elf() -> Path:
    """The firmware ELF, built, with the simboard harness (tools/simboard) built beside it.
    Skips with the reason when the AVR toolchain, libsimavr-dev, make or porosense.simboard is
    missing; a build that fails is a test failure."""
    from porosense.bench import firmware as fw

    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    if not Path("/usr/include/simavr/sim_avr.h").is_file():
        pytest.skip("libsimavr-dev not installed")
    if shutil.which("make") is None:
        pytest.skip("make not found")
    try:
        from porosense.simboard import SimBoard  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"porosense.simboard not available: {exc}")
    proc = fw.build()
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    r = subprocess.run(["make", "-s", "-C", str(ROOT / "tools" / "simboard")], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return fw.ELF
