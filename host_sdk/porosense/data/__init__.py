"""Recordings and tables: the data formats of porosense.

- :class:`Recording` -- timestamped multi-channel record with metadata; CSV + JSON sidecar
  and MATLAB .mat I/O that round-trip exactly.
- :func:`read_table` -- any numeric CSV with a header row (e.g. the measured benchmark files)
  as named columns, with clear errors naming file, line and column.
"""

from porosense.data.recording import Recording
from porosense.data.table import Table, read_table

__all__ = ["Recording", "Table", "read_table"]
