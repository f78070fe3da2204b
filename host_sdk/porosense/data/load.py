"""Any recording a user brings, as named columns with its sample period: ``load_data``.

Like MATLAB's ``iddata``: the signals come from a CSV of any common dialect or a ``.mat``
file, and the sample period Ts (s) comes from the data when the data states it -- a time
column (``t``, ``time``, ``t_s``), the JSON sidecar of a porosense recording, or a ``Ts``
variable in a .mat file. A ``--ts`` given by the user must agree with it (within 1 %), unless
the user says to override it: a wrong Ts silently scales every time constant.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from porosense.data.table import Table, read_table
from porosense.errors import InputError

TIME_COLUMNS = ("t", "time", "t_s", "Time")
TS_TOLERANCE = 0.01  # relative disagreement accepted between --ts and the data's own Ts


def _ts_from_sidecar(path: Path) -> float | None:
    side = path.with_suffix(".json")
    if not side.is_file():
        return None
    try:
        doc = json.loads(side.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, OSError):
        return None
    meta = doc.get("meta", {}) if isinstance(doc, dict) else {}
    if not isinstance(meta, dict):
        return None
    if isinstance(meta.get("ts"), (int, float)) and meta["ts"] > 0:
        return float(meta["ts"])
    if isinstance(meta.get("rate_hz"), (int, float)) and meta["rate_hz"] > 0:
        return 1.0 / float(meta["rate_hz"])
    return None


def time_column(table: Table) -> str | None:
    """Name of the table's time column (s), or None."""
    return next((c for c in TIME_COLUMNS if c in table.columns), None)


def _stated_ts(table: Table) -> tuple[float | None, str]:
    """(Ts in s, where it came from) as the file states it, or (None, '')."""
    tcol = time_column(table)
    if tcol is not None and len(table) >= 2:
        t = table.columns[tcol]
        if np.all(np.isfinite(t)):
            step = np.diff(t)
            ts = float(np.median(step))
            if ts > 0:
                return ts, f"the '{tcol}' column of {table.path.name}"
    if table.ts:
        return table.ts, table.ts_source
    side = _ts_from_sidecar(Path(table.path))
    if side:
        return side, f"{Path(table.path).with_suffix('.json').name}"
    return None, ""


def load_data(path, *, separator: str | None = None, decimal: str | None = None) -> Table:
    """Read a recording (``.mat`` v5/v7.3, or a text table of any common dialect) as a Table.

    The Table's ``ts``/``ts_source`` hold the sample period the file states (None when it
    states none).
    """
    path = Path(path)
    if path.suffix.lower() == ".mat":
        from porosense.data.matfile import read_mat

        table = read_mat(path)
    else:
        if path.is_file():
            with open(path, "rb") as fh:
                head = fh.read(128)
            if head.startswith(b"MATLAB") or head[:8] == b"\x89HDF\r\n\x1a\n":
                from porosense.data.matfile import read_mat

                table = read_mat(path)
                ts, source = _stated_ts(table)
                table.ts, table.ts_source = ts, source
                return table
        table = read_table(path, separator=separator, decimal=decimal)
    table.ts, table.ts_source = _stated_ts(table)
    table.units, table.meta = _sidecar_units_meta(path)
    return table


def _sidecar_units_meta(path: Path) -> tuple[dict, dict]:
    side = path.with_suffix(".json")
    try:
        doc = json.loads(side.read_text(encoding="utf-8")) if side.is_file() else {}
    except (json.JSONDecodeError, UnicodeDecodeError, OSError):
        return {}, {}
    if not isinstance(doc, dict):
        return {}, {}
    units, meta = doc.get("units", {}), doc.get("meta", {})
    return (
        {str(k): str(v) for k, v in units.items()} if isinstance(units, dict) else {},
        meta if isinstance(meta, dict) else {},
    )


def resolve_ts(tables, ts: float | None, override: bool = False) -> float:
    """The sample period (s) for ``tables``, checked against a user's ``ts`` (None: take the data's).

    Raises InputError when ``ts`` is not a positive finite number, when files disagree with
    each other, when ``ts`` disagrees with the data by more than 1 % (unless ``override``), or
    when neither states one.
    """
    if ts is not None and not (math.isfinite(ts) and ts > 0):
        raise InputError(f"--ts {ts}: the sample period must be a positive finite number of seconds")
    stated = [(t.ts, t.ts_source) for t in tables if t.ts]
    if ts is not None and override:
        return float(ts)
    if stated:
        ref, where = stated[0]
        for other, source in stated[1:]:
            if abs(other - ref) > TS_TOLERANCE * ref:
                raise InputError(
                    f"the files disagree on the sample period: {ref:g} s from {where}, {other:g} s from {source}"
                )
        if ts is not None and abs(ts - ref) > TS_TOLERANCE * ref:
            raise InputError(
                f"--ts {ts:g} s disagrees with {ref:g} s from {where} ({1 / ref:g} Hz); "
                "drop --ts, or add --ts-override to use it anyway"
            )
        return float(ts if ts is not None else ref)
    if ts is None:
        names = ", ".join(str(t.path) for t in tables)
        raise InputError(f"{names}: no time column ('t') and no stated Ts: pass --ts SECONDS")
    return float(ts)
