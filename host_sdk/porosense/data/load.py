"""Any recording a user brings, as named columns with its sample period: ``load_data``.

Like MATLAB's ``iddata``: the signals come from a CSV of any common dialect or a ``.mat``
file, and the sample period Ts (s) comes from the data when the data states it -- a time
column (``t``, ``time``, ``t_ms``, ...; its unit checked by :func:`check_sampling`), the JSON
sidecar of a porosense recording, or a ``Ts`` variable in a .mat file. A ``--ts`` given by the user must agree with it (within 1 %), unless
the user says to override it: a wrong Ts silently scales every time constant.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from porosense.data.sampling import check_sampling
from porosense.data.table import Table, read_table
from porosense.errors import InputError

TS_TOLERANCE = 0.01  # relative disagreement accepted between --ts and the data's own Ts


def _sidecar(path: Path) -> dict:
    side = path.with_suffix(".json")
    if not side.is_file():
        return {}
    try:
        doc = json.loads(side.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, OSError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _ts_from_meta(meta) -> float | None:
    if not isinstance(meta, dict):
        return None
    ts, rate = meta.get("ts"), meta.get("rate_hz")
    if isinstance(ts, (int, float)) and math.isfinite(ts) and ts > 0:
        return float(ts)
    if isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0:
        return 1.0 / float(rate)
    return None


def load_data(
    path,
    *,
    separator: str | None = None,
    decimal: str | None = None,
    time_unit: str | None = None,
    resample: bool = False,
    skip_rows: int = 0,
    check: bool = True,
) -> Table:
    """Read a recording (``.mat`` v5/v7.3, or a text table of any common dialect) as a Table.

    Parameters
    ----------
    path : str or Path
        The file. A JSON sidecar beside it (``name.json``) adds units and metadata.
    separator, decimal : str, optional
        Override the detected CSV dialect.
    time_unit : {'s', 'ms', 'us'}, optional
        Unit of the time column (default: stated by the file or inferred, see check_sampling).
    resample : bool
        Interpolate a record with gaps or repeated stamps onto a uniform grid (else refused).
    skip_rows : int
        Lines to skip before a CSV's header.
    check : bool
        Check the time base with :func:`porosense.data.check_sampling` (default; off only for
        tables that are not sampled records, such as a trajectory's way points).

    Returns
    -------
    Table
        Columns, ``ts``/``ts_source`` (the sample period in s the file states, None when it
        states none), ``units``, ``meta``, ``time`` (the time column in s) and ``sampling``.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if _is_matlab(path):
        from porosense.data.matfile import read_mat

        table = read_mat(path)
    else:
        table = read_table(path, separator=separator, decimal=decimal, skip_rows=skip_rows)
    side = _sidecar(path)
    units, meta = side.get("units", {}), side.get("meta", {})
    if isinstance(units, dict) and units:
        stated = {str(k): str(v) for k, v in units.items()}
        table.units = {**stated, **table.units}  # the file's own units row wins over the sidecar
        table.units_source = table.units_source or f"the sidecar {path.with_suffix('.json').name}"
    own = getattr(table, "meta", None) or {}  # a .mat file's own metadata (Recording.to_mat)
    from_sidecar = isinstance(meta, dict) and bool(meta)
    table.meta = meta if from_sidecar else own
    if not table.ts:
        side_ts = _ts_from_meta(table.meta)
        if side_ts:
            where = path.with_suffix(".json").name if from_sidecar else f"the recording's metadata in {path.name}"
            table.ts, table.ts_source = side_ts, where
    if check:
        check_sampling(table, time_unit=time_unit, resample=resample)
    return table


def _is_matlab(path: Path) -> bool:
    if path.suffix.lower() == ".mat":
        return True
    if not path.is_file():
        return False
    with open(path, "rb") as fh:
        head = fh.read(520)
    return head.startswith(b"MATLAB") or b"\x89HDF\r\n\x1a\n" in (head[:8], head[512:520])


def resolve_ts(tables, ts: float | None, override: bool = False) -> float:
    """The sample period for ``tables``, checked against a user's ``ts``.

    Parameters
    ----------
    tables : sequence of Table
        Tables as loaded (``load_data``), with the period each states (``Table.ts``) if any.
    ts : float or None
        The user's sample period, s (None: take the data's).
    override : bool
        Use ``ts`` even where it disagrees with the data.

    Returns
    -------
    float
        The sample period, s.

    Raises
    ------
    InputError
        ``ts`` not a positive finite number, files that disagree with each other, ``ts`` that
        disagrees with the data by more than 1 % (unless ``override``), or no period at all.
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
