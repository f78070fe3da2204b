"""Flash the packaged Uno firmware (HEX) with avrdude: what `make -C firmware upload` does,
without the source tree."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from porosense.errors import DeviceError, InputError
from porosense.firmware.files import hex_path

MCU = "atmega328p"
PROGRAMMER = "arduino"  # the Uno's optiboot bootloader
BAUD = 115200


@dataclass
class UploadResult:
    """What avrdude flashed: the HEX file, the port and avrdude's last line."""

    hex: str
    port: str
    message: str

    def to_dict(self) -> dict:
        return {"hex": self.hex, "port": self.port, "message": self.message}

    def __str__(self) -> str:
        return f"flashed {self.hex} to {self.port}: {self.message}"


def avrdude_command(port: str, hex_file: Path, avrdude: str = "avrdude") -> list[str]:
    """The avrdude command line for an Uno on ``port`` (-D: the bootloader erases per page)."""
    return [avrdude, "-p", MCU, "-c", PROGRAMMER, "-P", port, "-b", str(BAUD), "-D", "-U", f"flash:w:{hex_file}:i"]


def upload(
    port: str, hex_file: Path | str | None = None, avrdude: str | None = None, timeout_s: float = 120.0
) -> UploadResult:
    """Flash ``hex_file`` (default: the packaged firmware) to the Uno on ``port``."""
    hex_file = Path(hex_file) if hex_file else hex_path()
    if not hex_file.is_file():
        raise InputError(
            f"no firmware HEX at {hex_file}: this installation carries none "
            "(build it with `make -C firmware` in a checkout and reinstall)"
        )
    tool = avrdude or shutil.which("avrdude")
    if tool is None:
        raise DeviceError("avrdude not found: install it (Debian/Ubuntu: sudo apt-get install avrdude)")
    try:
        proc = subprocess.run(avrdude_command(port, hex_file, tool), capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise DeviceError(f"avrdude gave no answer from {port} within {timeout_s:.0f} s") from None
    lines = [ln.strip() for ln in (proc.stderr + proc.stdout).splitlines() if ln.strip()]
    if proc.returncode != 0:
        why = next(
            (ln for ln in reversed(lines) if "error" in ln.lower() or "can't" in ln.lower()),
            lines[-1] if lines else f"exit status {proc.returncode}",
        )
        raise DeviceError(f"avrdude could not flash {port}: {why}")
    return UploadResult(str(hex_file), port, lines[-1] if lines else "done")
