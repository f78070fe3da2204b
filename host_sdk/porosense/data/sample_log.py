"""A recording written while it is made: a CSV that gains its rows as the samples arrive and is
flushed to the disk at least every ``flush_s`` seconds, so that a command killed at any moment
(SIGKILL, a power cut of the host) leaves every sample up to the last flush readable. The
command writes its complete recording over it when it ends normally."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

FLUSH_S = 1.0


class SampleLog:
    """Rows of numbers under a header, appended and flushed (``os.fsync``) at least every
    ``flush_s`` seconds of wall time.

    Parameters
    ----------
    path : path
        The CSV to write (replaced).
    names : list of str
        Column names of every row.
    flush_s : float
        Seconds between flushes to the disk.
    """

    def __init__(self, path, names, flush_s: float = FLUSH_S) -> None:
        self.path = Path(path)
        self.names = list(names)
        self.flush_s = float(flush_s)
        self.rows = 0
        self._fh = open(self.path, "w", encoding="utf-8")  # noqa: SIM115 - held for the run
        self._fh.write(",".join(self.names) + "\n")
        self._sync()

    def _sync(self) -> None:
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._last = time.monotonic()

    def append(self, values) -> None:
        """One row (numbers in the order of ``names``; NaN written empty)."""
        self._fh.write(",".join("" if isinstance(v, float) and math.isnan(v) else repr(v) for v in values) + "\n")
        self.rows += 1
        if time.monotonic() - self._last >= self.flush_s:
            self._sync()

    def close(self) -> None:
        """Flush what is left and close the file."""
        if not self._fh.closed:
            self._sync()
            self._fh.close()

    def __enter__(self) -> SampleLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
