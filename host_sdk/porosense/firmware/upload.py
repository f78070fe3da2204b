"""Flash the packaged Uno firmware (HEX) with avrdude: what `make -C firmware upload` does,
without the source tree."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from porosense.errors import DeviceError, InputError
from porosense.firmware.files import hex_path
from porosense.protocol import model_layout as L

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


def image_end(hex_file: Path) -> int:
    """The first flash byte after the data of a firmware HEX (bytes).

    Raises
    ------
    InputError
        When the file is not Intel HEX or holds no data.
    """
    from intelhex import IntelHex, IntelHexError

    ih = IntelHex()
    try:
        ih.loadhex(str(hex_file))
    except (IntelHexError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{hex_file} is not an Intel HEX file: {exc}") from None
    if not ih.addresses():
        raise InputError(f"{hex_file} holds no data")
    return ih.maxaddr() + 1


def check_image(hex_file: Path) -> int:
    """Refuse a firmware image that would overlap the flash model store: the board would run
    code that the next model upload overwrites. Returns the image's end (bytes)."""
    end = image_end(hex_file)
    if end > L.FLASH_BASE:
        raise InputError(
            f"{hex_file} ends at byte {end:,}, inside the flash model store ({L.FLASH_BASE:,}..{L.BOOTLOADER_BASE - 1:,}): "
            f"the image is {end - L.FLASH_BASE:,} B over its budget (make -C firmware size)"
        )
    return end


def upload(
    port: str,
    hex_file: Path | str | None = None,
    avrdude: str | None = None,
    timeout_s: float = 120.0,
    image: bool = True,
) -> UploadResult:
    """Flash ``hex_file`` (default: the packaged firmware) to the Uno on ``port``.

    Parameters
    ----------
    port : str
        Serial port of the Uno (its bootloader answers there after the port opens).
    hex_file : path, optional
        Intel HEX to write (default: the packaged firmware).
    avrdude : str, optional
        avrdude executable (default: found on PATH).
    timeout_s : float
        Seconds to wait for avrdude.
    image : bool
        True for a firmware image, which must end below the flash model store; False for a
        flash-store slot (porosense flash --store flash).
    """
    hex_file = Path(hex_file) if hex_file else hex_path()
    if not hex_file.is_file():
        raise InputError(
            f"no firmware HEX at {hex_file}: this installation carries none "
            "(build it with `make -C firmware` in a checkout and reinstall)"
        )
    if image:
        check_image(hex_file)
    tool = avrdude or shutil.which("avrdude")
    if tool is None:
        raise DeviceError("avrdude not found: install it (Debian/Ubuntu: sudo apt-get install avrdude)")
    try:
        proc = subprocess.run(avrdude_command(port, hex_file, tool), capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise DeviceError(f"avrdude gave no answer from {port} within {timeout_s:.0f} s") from None
    lines = [ln.strip() for ln in (proc.stderr + proc.stdout).splitlines() if ln.strip()]
    if proc.returncode != 0:
        # avrdude also complains about the DTR/RTS ioctls of ports that have none (a
        # pseudo-terminal): not why an upload failed.
        telling = [ln for ln in lines if "ioctl" not in ln]
        why = next(
            (ln for ln in reversed(telling) if "error" in ln.lower() or "can't" in ln.lower()),
            telling[-1] if telling else f"exit status {proc.returncode}",
        )
        raise DeviceError(f"avrdude could not flash {port}: {why}")
    return UploadResult(str(hex_file), port, lines[-1] if lines else "done")
