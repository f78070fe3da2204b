"""Recordings and tables: the data formats of porosense.

- :class:`Recording` -- timestamped multi-channel record with metadata; CSV + JSON sidecar
  and MATLAB .mat I/O that round-trip exactly.
- :func:`read_table` -- any numeric CSV with a header row (e.g. the measured benchmark files)
  as named columns, with clear errors naming file, line and column.
- :func:`load_data` -- a user's recording (.mat v5/v7.3, or CSV of any common dialect) with
  the sample period it states, and :func:`resolve_ts` to check a given Ts against it.
"""

from porosense.data.load import load_data, resolve_ts, time_column
from porosense.data.recording import Recording
from porosense.data.table import Dialect, Table, read_table, sniff_dialect

__all__ = ["Dialect", "Recording", "Table", "load_data", "read_table", "resolve_ts", "sniff_dialect", "time_column"]
