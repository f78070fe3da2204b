"""Recordings and tables: the data formats of porosense.

- :class:`Recording` -- timestamped multi-channel record with metadata; CSV + JSON sidecar
  and MATLAB .mat I/O that round-trip exactly.
- :func:`read_table` -- any numeric CSV with a header row (e.g. the measured benchmark files)
  as named columns, with clear errors naming file, line and column.
- :func:`load_data` -- a user's recording (.mat v5/v7.3, or CSV of any common dialect) with
  the sample period it states, and :func:`resolve_ts` to check a given Ts against it.
- :func:`check_sampling` -- the time base of a table checked and stated: time unit, monotonic
  and uniform stamps, gaps refused or resampled (every command's data pass through it).
"""

from porosense.data.dataset import Dataset
from porosense.data.load import load_data, resolve_ts
from porosense.data.recording import Recording
from porosense.data.sampling import Sampling, check_sampling, time_column
from porosense.data.table import Dialect, Table, read_table, sniff_dialect

__all__ = [
    "Dataset",
    "Dialect",
    "Recording",
    "Sampling",
    "Table",
    "check_sampling",
    "load_data",
    "read_table",
    "resolve_ts",
    "sniff_dialect",
    "time_column",
]
