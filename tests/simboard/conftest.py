"""Fixtures of the simboard tests: the harness and bring-up firmware, built once per run."""

from __future__ import annotations

import fcntl
import shutil
import subprocess
from pathlib import Path

import pytest
import serial

ROOT = Path(__file__).resolve().parents[2]
SIMBOARD_DIR = ROOT / "tools" / "simboard"
HARNESS = SIMBOARD_DIR / "build" / "simboard"
TESTFW = SIMBOARD_DIR / "build" / "testfw" / "testfw.elf"


def _missing_toolchain() -> str | None:
    if not Path("/usr/include/simavr/sim_avr.h").is_file():
        return "libsimavr is missing (apt-get install libsimavr-dev libelf-dev)"
    if shutil.which("avr-gcc") is None:
        return "avr-gcc is missing (apt-get install gcc-avr avr-libc arduino-core-avr)"
    return None


@pytest.fixture(scope="session")
def simboard_built() -> Path:
    """Builds tools/simboard (harness + bring-up firmware) once; skips without libsimavr."""
    reason = _missing_toolchain()
    if reason:
        pytest.skip(reason)
    # xdist workers share the build tree: one make at a time
    (SIMBOARD_DIR / "build").mkdir(exist_ok=True)
    with open(SIMBOARD_DIR / "build" / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        r = subprocess.run(["make", "-s", "-C", str(SIMBOARD_DIR)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"make -C tools/simboard failed:\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
    return HARNESS


@pytest.fixture(scope="session")
def testfw(simboard_built) -> Path:
    return TESTFW


class Console:
    """The bring-up firmware's line protocol over the board's serial URL."""

    def __init__(self, url: str, timeout: float = 10.0):
        self.port = serial.serial_for_url(url, timeout=timeout)
        self.sync()

    def sync(self) -> None:
        """Skips whatever the firmware sent before (a boot banner cut by the connect)."""
        self.port.write(b"\nesync\n")
        while self.read_line() != "esync":
            pass

    def ask(self, command: str) -> str:
        """Sends one command line and returns its reply line (boot banners skipped)."""
        self.port.write(command.encode() + b"\n")
        while True:
            line = self.port.readline()
            if not line.endswith(b"\n"):
                raise TimeoutError(f"no reply to {command!r} (got {line!r})")
            text = line.decode().strip()
            if not text.startswith("boot"):
                return text

    def read_line(self) -> str:
        line = self.port.readline()
        if not line.endswith(b"\n"):
            raise TimeoutError(f"no line (got {line!r})")
        return line.decode().strip()

    def close(self) -> None:
        self.port.close()


@pytest.fixture
def console_for():
    """console_for(board) -> Console, closed at the end of the test."""
    opened = []

    def make(board) -> Console:
        c = Console(board.url)
        opened.append(c)
        return c

    yield make
    for c in opened:
        c.close()
