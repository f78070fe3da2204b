"""No partial output from a command that did not finish (docs/cli.md, "Output files").

Files are written whole by :mod:`porosense.files`; this guard adds that a command stopped by an
error or Ctrl-C leaves nothing it created behind: the files and folders named by its output
options that did not exist when it started are removed. Files that existed are never removed
(atomic writes keep their old content until a new one is whole).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from pathlib import Path

# Options whose value names a file or folder the command writes.
OUTPUT_OPTIONS = (
    "out",
    "save",
    "json_out",
    "plot",
    "report",
    "header",
    "c_out",
    "control_out",
    "hex_out",
    "save_extended",
    "preview",
    "mat_out",
)
MAX_LISTED = 20000  # files listed in an existing output folder; beyond this its new files are left


def _listing(folder: Path) -> set | None:
    seen = set()
    for root, _, files in os.walk(folder):
        for f in files:
            seen.add(os.path.join(root, f))
            if len(seen) > MAX_LISTED:
                return None
    return seen


class OutputGuard:
    """Context manager: on an exception, remove what the command's output options created."""

    def __init__(self, args):
        values = [getattr(args, name, None) for name in OUTPUT_OPTIONS]
        self.paths = [Path(v) for v in values if isinstance(v, (str, os.PathLike))]
        self.before: dict = {}
        self.started = 0.0

    def __enter__(self):
        self.started = time.time()
        for p in self.paths:
            self.before[p] = _listing(p) if p.is_dir() else p.exists()
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            with contextlib.suppress(OSError):
                self._remove_created()
        return False

    def _remove_created(self) -> None:
        for p, was in self.before.items():
            if was is False and p.exists():
                if p.is_dir() and not p.is_symlink():
                    shutil.rmtree(p, ignore_errors=True)
                else:
                    p.unlink()
            elif isinstance(was, set) and p.is_dir():
                now = _listing(p) or set()
                for f in now - was:
                    with contextlib.suppress(OSError):
                        if os.path.getmtime(f) >= self.started - 1.0:
                            os.unlink(f)
