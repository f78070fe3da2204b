"""Build steps pyproject.toml cannot declare: the firmware files that a wheel carries.

* The device core (firmware/lib/core, reached through the porosense/firmware/core link) is
  compiled for this computer into porosense/firmware/lib/ with the C++ compiler; without a
  compiler the build stops with one line saying what to install.
* From a source checkout, the Uno firmware (ELF, HEX) and the simboard harness are built
  when their toolchains are present (gcc-avr; libsimavr-dev) and packaged; without them the
  wheel still installs, and the commands that need them say what is missing.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
REPO = HERE.parent  # only when building from a checkout; the package never looks here


def _make(folder: Path, tool: str, what: str) -> None:
    if not (folder / "Makefile").is_file() or shutil.which(tool) is None:
        print(f"porosense build: {what} not built ({tool} or {folder} missing); not packaged", file=sys.stderr)
        return
    proc = subprocess.run(["make", "-s", "-C", str(folder)], capture_output=True, text=True)
    if proc.returncode != 0:
        print(f"porosense build: {what} failed to build; not packaged:\n{proc.stderr[-2000:]}", file=sys.stderr)


class BuildWithFirmware(build_py):
    def run(self):
        if not getattr(self, "editable_mode", False):
            _make(REPO / "firmware", "avr-gcc", "the Uno firmware")
            _make(REPO / "tools" / "simboard", "cc", "the simboard harness")
        super().run()
        if getattr(self, "editable_mode", False):
            return  # a checkout builds the core library on first use (porosense.firmware.hostlib)
        sys.path.insert(0, str(HERE))
        try:
            from porosense.errors import PorosenseError
            from porosense.firmware import hostlib
        finally:
            sys.path.pop(0)
        pkg = Path(self.build_lib) / "porosense" / "firmware"
        lib = pkg / "lib" / hostlib.LIB_NAME
        try:
            hostlib.build(lib, src=pkg / "core")
        except PorosenseError as exc:
            raise SystemExit(f"porosense: {exc}") from None
        lib.with_suffix(".sha256").write_text(hostlib.digest(pkg / "core") + "\n")


class BinaryDistribution(Distribution):
    """The wheel holds a compiled library: tag it for this platform."""

    def has_ext_modules(self):
        return True


setup(cmdclass={"build_py": BuildWithFirmware}, distclass=BinaryDistribution)
