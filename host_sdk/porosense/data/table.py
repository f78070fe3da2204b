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
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import InputError

_NAN = math.nan


@dataclass
class Table:
    """Numeric columns of a CSV file (or .mat variables), in file order.

    Attributes
    ----------
    path : Path
        The file read.
    names : list of str
        Column names in file order.
    columns : dict of str to ndarray
        Name to a float64 array, NaN where a cell was empty.
    groups : dict of str to list of str
        A header name that spans several columns to their names (``"r" -> ["r_0", "r_1"]``).
    lines : ndarray or None
        File line (1-based) of each row, for error messages.
    dialect : str
        What the reader saw (``"comma-separated"``, ...), for error messages.
    ts : float or None
        Sample period the file states (time column, sidecar, Ts variable), s.
    ts_source : str
        Where ``ts`` came from.
    units : dict of str to str
        Column to unit, where the file states them.
    meta : dict
        The recording's metadata (porosity, load_g, ...): its JSON sidecar's, or a .mat file's own.
    units_source : str
        Where the units came from (``"the units row"``, ``"the sidecar"``, ...).
    time_unit : str or None
        Unit of a stated Ts without a time column (a .mat TimeUnit): ``"s"``, ``"ms"`` or ``"us"``.
    time : ndarray or None
        The time column in s (set by check_sampling).
    sampling : Sampling or None
        What check_sampling found.
    skipped : dict of str to str
        Variables left out, name to why (.mat files).
    """

    path: Path
    names: list[str]
    columns: dict[str, np.ndarray]
    groups: dict[str, list[str]] = field(default_factory=dict)
    lines: np.ndarray | None = None  # file line (1-based) of each row, for error messages
    dialect: str = "comma-separated"  # what the reader saw, for error messages
    ts: float | None = None  # sample period (s) the file states (t column, sidecar, Ts variable)
    ts_source: str = ""  # where ts came from
    units: dict = field(default_factory=dict)  # column -> unit, when the file states them
    meta: dict = field(default_factory=dict)  # the recording's metadata (porosity, load_g, ...)
    units_source: str = ""  # where the units came from ("the units row", "the sidecar", ...)
    time_unit: str | None = None  # unit of a stated Ts without a time column (a .mat TimeUnit)
    time: np.ndarray | None = field(default=None, repr=False)  # the time column in s (check_sampling)
    sampling: object = field(default=None, repr=False)  # the Sampling check_sampling found
    skipped: dict = field(default_factory=dict)  # variables left out, name -> why (.mat files)

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
        """The columns under a header stacked as one array.

        Parameters
        ----------
        name : str
            A header name spanning several columns, or a plain column name.

        Returns
        -------
        ndarray, shape (N, k)
            k = 1 for a plain column.

        Raises
        ------
        InputError
            No such column or group.
        """
        members = self.groups.get(name, [name] if name in self.columns else None)
        if members is None:
            raise InputError(f"{self.path}: no column group named '{name}'")
        return np.column_stack([self.columns[m] for m in members])

    def __repr__(self) -> str:
        return f"Table({str(self.path)!r}, {len(self)} rows, columns={self.names})"

    def line_of(self, row: int) -> str:
        """Where a data row sits in the file, for messages.

        Parameters
        ----------
        row : int
            Data row, 0-based.

        Returns
        -------
        str
            ``"line N"`` (1-based file line), or ``"row N"`` when unknown.
        """
        if self.lines is not None and 0 <= row < len(self.lines):
            return f"line {int(self.lines[row])}"
        return f"row {row + 1}"

    def require_finite(self, names, rows: slice = slice(None), what: str = "") -> None:
        """Raise InputError naming the first empty or non-finite cell of the columns within the rows.

        Parameters
        ----------
        names : sequence of str
            Columns checked.
        rows : slice
            Rows checked (default all).
        what : str
            What the columns are for, added to the message.

        Raises
        ------
        InputError
            An empty, NaN or infinite cell (file, line and column named).
        """
        index = np.arange(len(self))[rows]
        for name in names:
            bad = index[~np.isfinite(np.asarray(self[name], dtype=float)[rows])]
            if bad.size:
                cell = "empty or NaN" if np.isnan(self[name][bad[0]]) else "infinite"
                raise InputError(
                    f"{self.path}: {self.line_of(int(bad[0]))}, column '{name}': {cell} cell"
                    f"{' in the ' + what if what else ''} ({bad.size} such cells in this column)"
                )


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


_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+([eE][+-]?\d+)?\s*$")
_NUMBER = re.compile(r"^\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*$|^\s*[+-]?(nan|inf)\s*$", re.I)
_SEPARATOR_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", " ": "whitespace", "|": "bar"}


@dataclass(frozen=True)
class Dialect:
    """How a text table is written.

    Attributes
    ----------
    separator : str
        Cell separator: ``","``, ``";"``, ``"\\t"``, ``"|"``, or ``" "`` for any whitespace.
    decimal : str
        Decimal mark, ``"."`` or ``","``.
    header : bool
        Whether the first line names the columns.
    """

    separator: str = ","
    decimal: str = "."
    header: bool = True

    def describe(self) -> str:
        """The dialect in words.

        Returns
        -------
        str
            E.g. ``"semicolon-separated, decimal comma, a header row"``.
        """
        return (
            f"{_SEPARATOR_NAMES.get(self.separator, repr(self.separator))}-separated, decimal "
            f"{'comma' if self.decimal == ',' else 'point'}, {'a' if self.header else 'no'} header row"
        )


def sniff_dialect(lines: list[str]) -> Dialect:
    """Guess the dialect from the first non-blank lines (spreadsheet and MATLAB writetable styles).

    A separator is taken when most lines hold it the same number of times (the header may
    differ by a trailing separator); semicolons and tabs win over commas, because a
    comma between digits is then a decimal mark (European spreadsheets).

    Parameters
    ----------
    lines : list of str
        The file's first lines (up to 50 non-blank ones are read).

    Returns
    -------
    Dialect
        The guess; the default (comma, point, header) for no lines.
    """
    sample = [ln for ln in lines if ln.strip()][:50]
    if not sample:
        return Dialect()
    body = sample[1:] or sample

    def steady(sep):
        # The same count on most lines (a damaged line is reported later with its number).
        counts = [ln.count(sep) for ln in sample]
        mode = max(set(counts), key=counts.count)
        return mode > 0 and counts.count(mode) >= 0.6 * len(counts)

    if steady(";"):
        sep = ";"
    elif steady("\t"):
        sep = "\t"
    elif steady(",") or any("," in ln for ln in sample):
        sep = ","
    elif all(len(ln.split()) == len(body[0].split()) > 1 for ln in body):
        sep = " "
    elif steady("|"):
        sep = "|"
    else:
        sep = ","  # one column
    split = (lambda ln: ln.split()) if sep == " " else (lambda ln: ln.split(sep))
    decimal = "."
    if sep != ",":
        cells = [c.strip().strip('"') for ln in body for c in split(ln)]
        if any(_DECIMAL_COMMA.match(c) for c in cells):
            decimal = ","
    elif any(_DECIMAL_COMMA.match(c) for row in csv.reader(body) for c in row):
        decimal = ","  # quoted decimal commas with comma separators: "0,01","1,5"
    first = [c.strip().strip('"') for c in split(sample[0]) if c.strip()]
    if decimal == ",":
        first = [c.replace(",", ".") for c in first]
    header = not (first and all(_NUMBER.match(c) for c in first))
    return Dialect(sep, decimal, header)


def _normalise(text: str, dialect: Dialect) -> str:
    """Text of ``dialect`` rewritten as comma-separated with decimal points."""
    if dialect.separator == "," and dialect.decimal == ".":
        return text
    out = []
    if dialect.separator == "," and dialect.decimal == ",":
        # Decimal commas inside quoted cells ("1,5","2,25"): the csv module keeps quotes apart.
        for ln in text.splitlines():
            cells = next(csv.reader([ln]), [])
            out.append(",".join(c.strip().replace(",", ".") for c in cells))
        return "\n".join(out) + "\n"
    for ln in text.splitlines():
        if dialect.decimal == ",":
            ln = ln.replace(",", ".")
        cells = ln.split() if dialect.separator == " " else ln.split(dialect.separator)
        out.append(",".join(c.strip() for c in cells))
    return "\n".join(out) + "\n"


def _blank_skipped(text: str, skip_rows: int, comment: str | None) -> str:
    """``text`` with its first ``skip_rows`` lines and its comment lines blanked (line numbers kept)."""
    lines = text.split("\n")
    for k, ln in enumerate(lines):
        if k < skip_rows or (comment and ln.lstrip().startswith(comment)):
            lines[k] = ""
    return "\n".join(lines)


def _units_row(cells: list[str]) -> bool:
    """A row of units under the header: some text, and no cell that reads as a number."""
    texts = [c.strip().strip('"') for c in cells]
    return any(texts) and not any(_NUMBER.match(c) or _DECIMAL_COMMA.match(c) for c in texts if c)


def _parse_cell(text: str) -> float:
    text = text.strip()
    return float(text) if text else _NAN


def read_table(
    path,
    *,
    separator: str | None = None,
    decimal: str | None = None,
    skip_rows: int = 0,
    comment: str | None = "#",
) -> Table:
    """Read the numeric text table at ``path`` into a :class:`Table`.

    The dialect is sniffed (:func:`sniff_dialect`): comma, semicolon, tab or whitespace
    separators, decimal commas, with or without a header row (without one, columns are
    named ``col1, col2, ...`` as MATLAB's readtable does with ``Var1``). ``separator`` and
    ``decimal`` override the guess (a comma separator with a decimal comma needs the numbers
    quoted: ``"1,5","2,25"``). The first ``skip_rows`` lines and lines starting with
    ``comment`` are skipped; a row of units right under the header (no cell a number) fills
    ``Table.units``.

    Parameters
    ----------
    path : str or Path
        The text file.
    separator : str or None
        Cell separator (None: sniffed).
    decimal : str or None
        Decimal mark, ``"."`` or ``","`` (None: sniffed).
    skip_rows : int
        Lines skipped at the top of the file.
    comment : str or None
        Lines starting with it are skipped (None: none).

    Returns
    -------
    Table
        The columns, float64, with the file line of each row.

    Raises
    ------
    InputError
        An absent, binary or empty file, a row with the wrong number of cells, or a cell that is
        not a number; the message names file, line, column and the dialect that was read.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: a folder, not a file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or type(exc).__name__})") from None
    if b"\x00" in raw[:4096]:
        raise InputError(
            f"{path}: a binary file, not a recording (--data takes CSV or MATLAB .mat files"
            f"{'; a .bin is a model blob from quantize' if path.suffix.lower() == '.bin' else ''})"
        )
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{path}: byte {exc.start} is not UTF-8 text: not a CSV (save it as UTF-8 text, or as a .mat file)"
        ) from None
    if text.lstrip()[:1] == "{":
        raise InputError(
            f"{path}: a JSON file, not a recording (--data takes CSV or MATLAB .mat files; "
            "a model file goes to --model)"
        )
    if skip_rows < 0:
        raise InputError(f"--skip-rows {skip_rows}: give a count of lines >= 0")
    text = _blank_skipped(text, skip_rows, comment)
    try:
        guess = sniff_dialect(text.splitlines()[: 51 + skip_rows])
    except csv.Error as exc:  # a field of more than 128 KB: not a table of numbers
        raise InputError(f"{path}: not a table of numbers ({exc})") from None
    dialect = Dialect(
        separator if separator is not None else guess.separator,
        decimal if decimal is not None else guess.decimal,
        guess.header,
    )
    seen = dialect.describe()
    hint = "; pass --separator and --decimal if this is not how the file is written"
    text = _normalise(text, dialect)
    if not dialect.header:
        first_at = next((k for k, ln in enumerate(text.splitlines()) if ln.strip()), 0)
        first = text.splitlines()[first_at] if text.strip() else ""
        n = len(first.split(","))
        lines_ = text.split("\n")
        lines_.insert(first_at, ",".join(f"col{k}" for k in range(1, n + 1)))
        text = "\n".join(lines_)
    rows = csv.reader(io.StringIO(text))
    line_shift = 0 if dialect.header else -1  # the header we added is not in the file
    try:
        header = next(rows)
        while not header:  # blank, comment or skipped lines above the header
            header = next(rows)
    except StopIteration:
        raise InputError(f"{path}: empty file, expected a header row") from None
    except csv.Error as exc:
        raise InputError(f"{path}: line {rows.line_num}: {exc}") from None
    if not any(c.strip() for c in header):
        raise InputError(f"{path}: line {rows.line_num + line_shift}: empty header row")
    # A trailing comma in the header leaves one empty cell: it names nothing.
    trailing_empty = len(header) > 1 and not header[-1].strip()
    width = len(header)
    names, groups = _header_names(header[:-1] if trailing_empty else header, path)
    n_named = len(names)

    data: list[list[float]] = []
    lines: list[int] = []
    units: dict[str, str] = {}
    try:
        for row in rows:
            line = rows.line_num + line_shift
            if not row or (len(row) == 1 and not row[0].strip()):
                continue  # blank line
            if not data and not units and dialect.header and _units_row(row[:n_named]):
                units = {n: c.strip().strip('"') for n, c in zip(names, row[:n_named]) if c.strip().strip('"')}
                continue
            if len(row) not in (width, n_named) and not (len(row) == width + 1 and not row[-1].strip()):
                above = not data and len(row) > n_named  # a title line taken for the header?
                raise InputError(
                    f"{path}: line {line}: expected {n_named} cells, found {len(row)} (read as {seen}{hint}"
                    + ("; or lines above the header: pass --skip-rows N" if above else "")
                    + ")"
                )
            try:
                values = [_parse_cell(c) for c in row[:n_named]]
            except ValueError:
                for col, cell in enumerate(row[:n_named], start=1):
                    try:
                        _parse_cell(cell)
                    except ValueError:
                        tip = "; pass --decimal ," if _DECIMAL_COMMA.match(cell) else hint
                        raise InputError(
                            f"{path}: line {line}, column {col} ('{names[col - 1]}'): "
                            f"'{cell.strip()}' is not a number (read as {seen}{tip})"
                        ) from None
                raise
            if trailing_empty and len(row) == width and row[-1].strip():
                raise InputError(f"{path}: line {line}, column {width}: value in a column without a header name")
            data.append(values)
            lines.append(line)
    except csv.Error as exc:
        raise InputError(f"{path}: line {rows.line_num}: {exc}") from None

    array = np.array(data, dtype=float).reshape(len(data), n_named)
    columns = {name: np.ascontiguousarray(array[:, k]) for k, name in enumerate(names)}
    return Table(
        path=path,
        names=names,
        columns=columns,
        groups=groups,
        lines=np.array(lines, dtype=int),
        dialect=seen,
        units=units,
        units_source="the units row" if units else "",
    )
