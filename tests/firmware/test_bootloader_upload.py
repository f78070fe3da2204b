"""The upload path a researcher with a real Uno takes, through the real bootloader: Optiboot runs
in simavr (tools/simboard --bootloader) with a blank application flash and its UART on a
pseudo-terminal that resets the board when opened (the Uno's DTR auto-reset);
`porosense firmware upload --port PTY` flashes the packaged firmware with avrdude -c arduino,
Optiboot starts it, and the host talks to it with HELLO. Then a model goes into the flash
store the same way (`porosense flash --store flash`, avrdude -D) and the board runs it.

Optiboot comes from arduino-core-avr. Its packaged optiboot_atmega328.hex (Debian's build with
gcc-avr 5.4) is 532 bytes and spills 20 bytes past the end of the flash, so it cannot run as
it is; the test then builds the same source with the package's Makefile and
LED_START_FLASHES=0 (494 bytes: no LED to blink on the simboard), otherwise unchanged."""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from porosense.bench import firmware as fw
from porosense.cli import main
from porosense.protocol import model_layout as L

OPTIBOOT_DIR = Path("/usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot")

pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]


def _hex_end(path: Path) -> int:
    """One past the highest data address of an Intel HEX (records read one by one: the
    packaged Optiboot's overlap with its own version bytes would stop a strict reader)."""
    end, base = 0, 0
    for line in path.read_text().split():
        n, addr, kind = int(line[1:3], 16), int(line[3:7], 16), int(line[7:9], 16)
        if kind == 4:
            base = int(line[9:13], 16) << 16
        elif kind == 0:
            end = max(end, base + addr + n)
    return end


@pytest.fixture(scope="module")
def optiboot(tmp_path_factory) -> Path:
    if not (OPTIBOOT_DIR / "optiboot_atmega328.hex").is_file():
        pytest.skip("arduino-core-avr's Optiboot not installed (Debian: arduino-core-avr)")
    packaged = OPTIBOOT_DIR / "optiboot_atmega328.hex"
    if _hex_end(packaged) <= L.BOOTLOADER_BASE + 512:
        return packaged
    work = tmp_path_factory.mktemp("optiboot")
    for f in OPTIBOOT_DIR.iterdir():
        if f.is_file() and f.suffix != ".hex":
            shutil.copy(f, work)
    proc = subprocess.run(
        [
            "make",
            "-C",
            str(work),
            "optiboot_atmega328.hex",
            "TARGET=atmega328",
            "MCU_TARGET=atmega328p",
            "AVR_FREQ=16000000L",
            "LDSECTIONS=-Wl,--section-start=.text=0x7e00 -Wl,--section-start=.version=0x7ffe",
            "DEFS=-DLED_START_FLASHES=0 -DBAUD_RATE=115200",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    built = work / "optiboot_atmega328.hex"
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert _hex_end(built) <= L.BOOTLOADER_BASE + 512, "Optiboot does not fit its 512 bytes"
    return built


@pytest.fixture(scope="module")
def tools(simboard_elf) -> None:
    """The firmware and the simboard harness built (tests/conftest.py), avrdude installed."""
    if shutil.which("avrdude") is None:
        pytest.skip("avrdude not installed (tools/bootstrap.sh installs it)")


def test_upload_through_optiboot_then_hello_then_flash_store(optiboot, tools, tmp_path, capsys) -> None:
    from porosense.device import Device
    from porosense.simboard import SimBoard
    from porosense.simboard.pty_link import PtyLink

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "device"))
    from models import make_blob

    blob_path = tmp_path / "model.bin"
    blob_path.write_bytes(make_blob(1))
    t0, cpu0 = time.monotonic(), resource.getrusage(resource.RUSAGE_CHILDREN)
    # Real time: Optiboot's 1 s window after a reset and its watchdog during the upload count
    # AVR time, which must not outrun avrdude.
    with SimBoard(elf=None, bootloader=optiboot, max_speed=1.0) as board, PtyLink(board) as pty:
        # Optiboot runs in real time beside avrdude's timeouts: on a computer too busy to keep
        # simavr at real time a sync can be missed, as with a real Uno; one retry, counted.
        attempts = 1
        while main(["firmware", "upload", "--port", pty.path]) != 0 and attempts < 2:
            attempts += 1
        out = capsys.readouterr().out
        assert f"to {pty.path}" in out and "flashed" in out, f"upload failed {attempts} times"
        t_upload = time.monotonic() - t0
        with Device.open(pty.path) as dev:  # resets the board, as opening a Uno's port does
            hello = dev.info
            assert hello.proto_major == 2 and "FLASH_STORE" in hello.capabilities
            assert dev.model_info().status == "none"
        code = main(["flash", "--port", pty.path, str(blob_path), "--store", "flash", "--set-rate"])
        err = capsys.readouterr()
        assert code == 0, err.err
        with Device.open(pty.path) as dev:
            info = dev.model_info()
        assert info.valid and info.store == "flash" and info.length == blob_path.stat().st_size
        resets = pty.resets
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.monotonic() - t0
    cpu_s = (cpu.ru_utime + cpu.ru_stime) - (cpu0.ru_utime + cpu0.ru_stime)
    print(
        f"upload through Optiboot ({fw.measure_size().flash} B): {t_upload:.1f} s wall; whole test "
        f"(upload, HELLO, flash-store upload, MODEL_INFO) {wall:.1f} s wall, {cpu_s:.1f} s CPU of child "
        f"processes, load {os.getloadavg()[0]:.1f}; {resets} resets by port opens; {attempts} upload attempt(s)"
    )
    assert resets >= 4  # avrdude, HELLO, flash's own HELLO and avrdude, MODEL_INFO
