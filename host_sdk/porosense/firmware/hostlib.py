"""The device core (firmware/lib/core) built for this computer as a shared library.

The library is compiled with the C++ compiler ($CXX, else c++ / g++ / clang++) from the
packaged sources. A wheel carries one built at install time; otherwise (a source checkout,
or sources changed since) it is built on first use into a cache folder
($POROSENSE_CACHE, else $XDG_CACHE_HOME/porosense, else ~/.cache/porosense), named by a
digest of the sources so that a change to the firmware rebuilds it.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

from porosense.errors import DeviceError
from porosense.firmware.files import HERE, core_dir

CXXFLAGS = ("-std=c++11", "-O2", "-fPIC", "-shared", "-fvisibility=hidden")
LIB_NAME = "libporosense_core" + (".dylib" if sys.platform == "darwin" else ".so")
PACKAGED_LIB = HERE / "lib" / LIB_NAME
MISSING_COMPILER = (
    "no C++ compiler found to build the firmware core: install one (Debian/Ubuntu: sudo apt-get install g++) or set CXX"
)

_lock = threading.Lock()
_built: Path | None = None


def compiler() -> str | None:
    """The C++ compiler to use, None when there is none."""
    env = os.environ.get("CXX")
    if env:
        return shutil.which(env) or (env if Path(env).is_file() else None)
    for name in ("c++", "g++", "clang++"):
        found = shutil.which(name)
        if found:
            return found
    return None


def sources(src: Path | None = None) -> list[Path]:
    """The core's C++ sources and headers."""
    src = core_dir() if src is None else Path(src)
    return sorted(p for p in src.iterdir() if p.suffix in (".cpp", ".h"))


def digest(src: Path | None = None) -> str:
    """SHA-256 (hex) of the sources and the flags: names the library built from them."""
    h = hashlib.sha256(" ".join(CXXFLAGS).encode())
    for p in sources(src):
        h.update(p.name.encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def build(dest: Path, src: Path | None = None) -> Path:
    """Compile the core into ``dest`` (atomically: concurrent builds do not collide)."""
    cxx = compiler()
    if cxx is None:
        raise DeviceError(MISSING_COMPILER)
    cpp = [str(p) for p in sources(src) if p.suffix == ".cpp"]
    if not cpp:
        raise DeviceError(f"no firmware core sources in {src or core_dir()}: the installation is incomplete")
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=dest.name + ".", suffix=".tmp", dir=dest.parent)
    os.close(fd)
    try:
        proc = subprocess.run([cxx, *CXXFLAGS, "-o", tmp, *cpp], capture_output=True, text=True)
        if proc.returncode != 0:
            first = next((ln for ln in proc.stderr.splitlines() if "error" in ln), proc.stderr.strip()[:300])
            raise DeviceError(f"building the firmware core with {cxx} failed: {first}")
        os.replace(tmp, dest)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return dest


def cache_dir() -> Path:
    env = os.environ.get("POROSENSE_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "porosense"


def library_path() -> Path:
    """The built core for the current sources: the packaged one when it matches them,
    else a cached build (made now when absent). $POROSENSE_CORE_LIB overrides."""
    global _built
    env = os.environ.get("POROSENSE_CORE_LIB")
    if env:
        return Path(env)
    with _lock:
        if _built is not None and _built.is_file():
            return _built
        want = digest()
        stamp = PACKAGED_LIB.with_suffix(".sha256")
        if PACKAGED_LIB.is_file() and stamp.is_file() and stamp.read_text().strip() == want:
            _built = PACKAGED_LIB
            return _built
        cached = cache_dir() / f"{LIB_NAME.rsplit('.', 1)[0]}-{want[:16]}{PACKAGED_LIB.suffix}"
        if not cached.is_file():
            build(cached)
        _built = cached
        return _built
