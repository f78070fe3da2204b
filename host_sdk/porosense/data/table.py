"""Read any numeric CSV with a header row into named columns.

The measured benchmark files this project meets use spreadsheet-style headers: a name over
a group of columns followed by empty header cells (``"r",,,"u",,``) and rows ending with a
trailing comma. ``read_table`` names such a group ``r_0, r_1, ...`` (a single column keeps
its name), drops a trailing column that is empty everywhere, reads empty cells as NaN, and
reports malformed content as :class:`porosense.errors.InputError` naming file, line and
column (both 1-based, as an editor shows them).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import InputError

_NAN = math.nan


@dataclass
class Table:
    """Numeric columns of a CSV file, in file order.

    ``columns[name]`` is a float64 array (NaN where a cell was empty); ``groups`` maps a
    header name that spans several columns to their names (``"r" -> ["r_0", "r_1"]``).
    """

    path: Path
    names: list[str]
    columns: dict[str, np.ndarray]
    groups: dict[str, list[str]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def __contains__(self, name: str) -> bool:
        return name in self.columns or name in self.groups

    def __getitem__(self, name: str) -> np.ndarray:
        """A column by name, or a header group as an (N, k) array."""
        if name in self.columns:
            return self.columns[name]
        if name in self.groups:
            return self.group(name)
        raise InputError(f"{self.path}: no column named '{name}' (columns: {', '.join(self.names)})")

    def group(self, name: str) -> np.ndarray:
        """The columns under header ``name`` stacked as an (N, k) array (k = 1 for a plain column)."""
        members = self.groups.get(name, [name] if name in self.columns else None)
        if members is None:
            raise InputError(f"{self.path}: no column group named '{name}'")
        return np.column_stack([self.columns[m] for m in members])

    def __repr__(self) -> str:
        return f"Table({str(self.path)!r}, {len(self)} rows, columns={self.names})"


def _header_names(cells: list[str], path: Path) -> tuple[list[str], dict[str, list[str]]]:
    """Column names from header cells; empty cells continue the group on their left."""
    spans: list[list] = []  # [name, count]
    for col, cell in enumerate(cells, start=1):
        name = cell.strip()
        if name:
            spans.append([name, 1])
        elif spans:
            spans[-1][1] += 1
        else:
            raise InputError(f"{path}: line 1, column {col}: the header starts with an empty name")
    names: list[str] = []
    groups: dict[str, list[str]] = {}
    for name, count in spans:
        members = [name] if count == 1 else [f"{name}_{i}" for i in range(count)]
        if count > 1:
            groups[name] = members
        names.extend(members)
    seen = set()
    for col, name in enumerate(names, start=1):
        if name in seen:
            raise InputError(f"{path}: line 1, column {col}: duplicate column name '{name}'")
        seen.add(name)
    return names, groups


def _parse_cell(text: str) -> float:
    text = text.strip()
    return float(text) if text else _NAN


def read_table(path) -> Table:
    """Read the CSV file at ``path`` (header row, numeric body) into a :class:`Table`.

    Raises :class:`InputError` for an absent or empty file, a row with the wrong number of
    cells, or a cell that is not a number; the message names file, line and column.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read as text ({exc})") from None
    rows = csv.reader(io.StringIO(text))
    try:
        header = next(rows)
    except StopIteration:
        raise InputError(f"{path}: empty file, expected a header row") from None
    except csv.Error as exc:
        raise InputError(f"{path}: line 1: {exc}") from None
    if not any(c.strip() for c in header):
        raise InputError(f"{path}: line 1: empty header row")
    # A trailing comma in the header leaves one empty cell: it names nothing.
    trailing_empty = len(header) > 1 and not header[-1].strip()
    width = len(header)
    names, groups = _header_names(header[:-1] if trailing_empty else header, path)
    n_named = len(names)

    data: list[list[float]] = []
    try:
        for row in rows:
            line = rows.line_num
            if not row or (len(row) == 1 and not row[0].strip()):
                continue  # blank line
            if len(row) not in (width, n_named) and not (len(row) == width + 1 and not row[-1].strip()):
                raise InputError(
                    f"{path}: line {line}: expected {n_named} cells, found {len(row)}"
                )
            try:
                values = [_parse_cell(c) for c in row[:n_named]]
            except ValueError:
                for col, cell in enumerate(row[:n_named], start=1):
                    try:
                        _parse_cell(cell)
                    except ValueError:
                        raise InputError(
                            f"{path}: line {line}, column {col} ('{names[col - 1]}'): "
                            f"'{cell.strip()}' is not a number"
                        ) from None
                raise
            if trailing_empty and len(row) == width and row[-1].strip():
                raise InputError(
                    f"{path}: line {line}, column {width}: value in a column without a header name"
                )
            data.append(values)
    except csv.Error as exc:
        raise InputError(f"{path}: line {rows.line_num}: {exc}") from None

    array = np.array(data, dtype=float).reshape(len(data), n_named)
    columns = {name: np.ascontiguousarray(array[:, k]) for k, name in enumerate(names)}
    return Table(path=path, names=names, columns=columns, groups=groups)
