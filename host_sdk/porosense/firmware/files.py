"""Where the packaged firmware files are (package-relative, never repository-relative)."""

from __future__ import annotations

import os
from pathlib import Path

HERE = Path(__file__).resolve().parent


def core_dir() -> Path:
    """The C++ sources of firmware/lib/core (the device's behaviour, written once)."""
    return HERE / "core"


def programs_dir() -> Path:
    """Measurement programs built around the core (AVR cycle counts, bit-exactness)."""
    return HERE / "programs"


def elf_path() -> Path:
    """The Uno firmware ELF (may not exist: an install without the AVR toolchain)."""
    return HERE / "avr" / "porosense.elf"


def hex_path() -> Path:
    """The Uno firmware as Intel HEX for avrdude."""
    return HERE / "avr" / "porosense.hex"


def harness_path() -> Path:
    """The simboard harness binary: $POROSENSE_SIMBOARD, else the packaged one."""
    env = os.environ.get("POROSENSE_SIMBOARD")
    return Path(env) if env else HERE / "simboard" / "simboard"


def source_tree() -> Path | None:
    """The source checkout this package runs from (found through the ``core`` link to
    firmware/lib/core), None for an installed package: developer tools that rebuild the
    firmware or the benchmarks need it; everything else uses the packaged files."""
    core = core_dir()
    if not core.is_symlink():
        return None
    root = core.resolve().parents[2]
    return root if (root / "firmware" / "Makefile").is_file() else None
