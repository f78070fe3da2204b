"""Shared fixtures: paths, the measured benchmark data, CI sizing."""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: glibc malloc settings of porosense.ident.heap (which sets them for fits only): blocks below
#: 32 MB come from the heap instead of their own mapping, and up to 64 MB freed stay there.
MMAP_THRESHOLD_B = 32 << 20
TRIM_THRESHOLD_B = 64 << 20


def _keep_freed_memory() -> None:
    """Stop glibc from unmapping every freed array of more than 128 kB (its default threshold
    moves up only after a free of a larger one), as porosense.ident.heap does for fits, for
    everything the tests run: a diagnosis allocates and frees arrays of a few hundred kB
    thousands of times, and the kernel's page faults on each new mapping cost 2.1 s of system
    time in 12 simulator diagnosis trials with 11.5 s of user time (0.01 s with these settings,
    the same user time and peak memory). Set here for this process and, through the
    environment, for the processes the tests start (xdist workers, the CLI, make demo); a C
    library other than glibc ignores both."""
    os.environ.setdefault("MALLOC_MMAP_THRESHOLD_", str(MMAP_THRESHOLD_B))
    os.environ.setdefault("MALLOC_TRIM_THRESHOLD_", str(TRIM_THRESHOLD_B))
    try:
        mallopt = ctypes.CDLL(None).mallopt
        mallopt(-3, int(os.environ["MALLOC_MMAP_THRESHOLD_"]))  # M_MMAP_THRESHOLD
        mallopt(-1, int(os.environ["MALLOC_TRIM_THRESHOLD_"]))  # M_TRIM_THRESHOLD
    except (OSError, AttributeError, ValueError):
        pass


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
