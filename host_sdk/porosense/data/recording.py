"""The Recording: a timestamped multi-channel record with metadata.

Columns and units follow docs/conventions.md (``t`` in s, ``dR_0`` in %, ``strain_0`` in %,
...). Metadata carries what produced the record: actuator, porosity (%), load (g), schedule,
sample rate (Hz), seed, effects, and which columns are ground truth.

Files:

- CSV (``name.csv``) with a JSON sidecar (``name.json``: meta, units, column order and
  dtypes). Floats are written with ``repr`` (shortest exact form), so a round trip returns
  bit-identical arrays.
- MATLAB ``.mat`` (scipy.io): ``t`` and one variable per column (N x 1), a ``units`` struct, a
  ``meta`` struct for reading in MATLAB, and ``recording_json`` with the exact metadata.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porosense.data.table import read_table
from porosense.errors import InputError
from porosense.files import atomic_path, write_text

FORMAT = "porosense.recording/1"


def _jsonable(value):
    """Metadata value -> plain JSON types (numpy scalars and arrays included)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def refuse_foreign_sidecar(path) -> None:
    """InputError when the JSON beside the CSV ``path`` exists and is not a recording's sidecar: a
    model or a parameter file of the same stem would be replaced by the recording's units
    (:meth:`Recording.to_csv` checks it; a command calls it before it computes the recording)."""
    side = Path(path).with_suffix(".json")
    if not side.is_file():
        return
    try:
        doc = json.loads(side.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        doc = None
    if isinstance(doc, dict) and (doc.get("format") == FORMAT or {"units", "columns"} <= doc.keys()):
        return
    raise InputError(
        f"{side} is not a recording's sidecar: writing {path.name} would replace it with the recording's units "
        "(give the output another name)"
    )


@dataclass
class Recording:
    """A record of samples at times ``t`` with named columns of equal length.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times, s.
    columns : dict of str to ndarray
        Column name (docs/conventions.md: ``dR_0`` in %, ``p_0`` in kPa, ``theta_x`` in deg,
        ...) to a 1-D array of N samples; ``t`` is not a column.
    meta : dict
        JSON-serialisable facts about the record (source, rate_hz, porosity, ...).
    units : dict of str to str
        Column name to its unit; ``t`` is ``"s"``.

    Raises
    ------
    InputError
        A column named ``t`` or one whose length differs from ``t``.
    """

    t: np.ndarray
    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float).ravel()
        cols = {}
        for name, values in self.columns.items():
            if name == "t":
                raise InputError("'t' is the time axis, not a column")
            arr = np.asarray(values).ravel()
            if arr.shape != self.t.shape:
                raise InputError(f"column '{name}' has {arr.size} samples, the time axis has {self.t.size}")
            cols[str(name)] = arr
        self.columns = cols
        self.meta = _jsonable(dict(self.meta))
        self.units = {str(k): str(v) for k, v in dict(self.units).items()}
        self.units.setdefault("t", "s")

    # --- access --------------------------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t":
            return self.t
        try:
            return self.columns[name]
        except KeyError:
            raise InputError(f"recording has no column '{name}' (columns: {', '.join(self.names)})") from None

    def __contains__(self, name: str) -> bool:
        return name == "t" or name in self.columns

    def __len__(self) -> int:
        return self.t.size

    @property
    def names(self) -> list[str]:
        """Column names in order (without ``t``)."""
        return list(self.columns)

    @property
    def ts(self) -> float:
        """Sample period (s): the median time step."""
        if self.t.size < 2:
            return float(1.0 / self.meta["rate_hz"]) if "rate_hz" in self.meta else float("nan")
        return float(np.median(np.diff(self.t)))

    @property
    def fs(self) -> float:
        """Sample rate (Hz)."""
        return 1.0 / self.ts

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.t[-1] - self.t[0]) if self.t.size else 0.0

    def matrix(self, names) -> np.ndarray:
        """Columns stacked as one array.

        Parameters
        ----------
        names : sequence of str
            Column names (``t`` allowed).

        Returns
        -------
        ndarray, shape (N, k)
            float64, one column per name, in the columns' units.

        Raises
        ------
        InputError
            A name the recording does not hold.
        """
        return np.column_stack([np.asarray(self[n], dtype=float) for n in names])

    def slice(self, t0: float, t1: float) -> Recording:
        """The samples with ``t0 <= t < t1``; times are kept, metadata copied (with ``slice_s``).

        Parameters
        ----------
        t0, t1 : float
            Start (included) and end (excluded), s.

        Returns
        -------
        Recording
            The part.
        """
        keep = (self.t >= t0) & (self.t < t1)
        return Recording(
            self.t[keep],
            {k: v[keep] for k, v in self.columns.items()},
            dict(self.meta, slice_s=[float(t0), float(t1)]),
            dict(self.units),
        )

    def with_columns(self, **columns) -> Recording:
        """A copy with columns added or replaced.

        Parameters
        ----------
        **columns : array_like
            Name to N samples.

        Returns
        -------
        Recording
            The copy (metadata and units copied).
        """
        return Recording(self.t, {**self.columns, **columns}, dict(self.meta), dict(self.units))

    def __repr__(self) -> str:
        what = ", ".join(
            f"{k}={self.meta[k]}" for k in ("actuator", "experiment", "porosity", "load_g") if k in self.meta
        )
        return (
            f"Recording({what + ', ' if what else ''}{len(self)} samples, {self.duration:.1f} s, columns={self.names})"
        )

    def to_dict(self) -> dict:
        """Plain-JSON form (lists), e.g. for reports.

        Returns
        -------
        dict
            ``t`` (s), ``columns``, ``meta`` and ``units``.
        """
        return {
            "t": self.t.tolist(),
            "columns": {k: v.tolist() for k, v in self.columns.items()},
            "meta": self.meta,
            "units": self.units,
        }

    def plot(self, names=None, ax=None):
        """Plot columns against time.

        Parameters
        ----------
        names : sequence of str or None
            Columns to plot (None: all).
        ax : matplotlib Axes or None
            Where to draw (None: a new figure).

        Returns
        -------
        matplotlib Axes
            The axes drawn on (time in s, legend with units).
        """
        import matplotlib.pyplot as plt

        ax = ax or plt.subplots(figsize=(8, 3))[1]
        for name in names or self.names:
            ax.plot(self.t, self[name], label=f"{name} [{self.units.get(name, '')}]")
        ax.set_xlabel("t [s]")
        ax.legend(loc="best", fontsize="small")
        return ax

    def _sidecar(self) -> dict:
        return {
            "format": FORMAT,
            "meta": self.meta,
            "units": self.units,
            "columns": self.names,
            "dtypes": {k: v.dtype.str for k, v in self.columns.items()},
        }

    # --- CSV + JSON sidecar --------------------------------------------------------------
    def to_csv(self, path) -> Path:
        """Write ``path`` (CSV, values that read back bit-identical) and ``path.with_suffix('.json')``
        (metadata, units, dtypes, column order), each whole or not at all.

        Parameters
        ----------
        path : str or Path
            The CSV file.

        Returns
        -------
        Path
            The CSV path.

        Raises
        ------
        InputError
            When a JSON of the same stem exists that is not a recording's sidecar (a model, a
            parameter file): nothing is written.
        """
        path = Path(path)
        refuse_foreign_sidecar(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        names = ["t"] + self.names
        cols = [self.t] + [self.columns[n] for n in self.names]
        # repr of a Python float is the shortest text that reads back bit-identical.
        as_text = [
            list(map(repr, c.astype(float).tolist())) if c.dtype.kind == "f" else list(map(str, c.astype(int).tolist()))
            for c in cols
        ]
        lines = [",".join(names)]
        lines.extend(",".join(row) for row in zip(*as_text))
        write_text(path, "\n".join(lines) + "\n")
        write_text(path.with_suffix(".json"), json.dumps(self._sidecar(), indent=1))
        return path

    @classmethod
    def from_csv(cls, path) -> Recording:
        """Read a CSV (and its JSON sidecar when present: meta, units, dtypes, order).

        Parameters
        ----------
        path : str or Path
            A CSV with a ``t`` column (s).

        Returns
        -------
        Recording
            The recording as written by :meth:`to_csv`.

        Raises
        ------
        InputError
            No ``t`` column, a malformed sidecar, columns it names missing, or a cell that is not a
            number (the message names file and line).
        """
        path = Path(path)
        table = read_table(path)
        if "t" not in table.columns:
            raise InputError(f"{path}: line 1: no 't' column (time in s)")
        sidecar = {}
        side_path = path.with_suffix(".json")
        if side_path.exists():
            try:
                sidecar = json.loads(side_path.read_text(encoding="utf-8"))
            except json.JSONDecodeError as exc:
                raise InputError(f"{side_path}: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
            if not isinstance(sidecar, dict):
                raise InputError(f"{side_path}: expected a JSON object")
        order = sidecar.get("columns", [n for n in table.names if n != "t"])
        missing = [n for n in order if n not in table.columns]
        if missing:
            raise InputError(f"{path}: columns named in {side_path.name} are missing: {missing}")
        dtypes = sidecar.get("dtypes", {})
        columns = {}
        for name in order:
            values = table.columns[name]
            dtype = np.dtype(dtypes.get(name, "<f8"))
            if dtype.kind in "iub":
                if not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
                    raise InputError(f"{path}: column '{name}' should hold integers")
                values = values.astype(dtype) if dtype.kind != "b" else values != 0
            columns[name] = values
        return cls(table.columns["t"], columns, sidecar.get("meta", {}), sidecar.get("units", {}))

    # --- MATLAB -------------------------------------------------------------------------
    def to_mat(self, path) -> Path:
        """Write a MATLAB .mat file (v5, readable by MATLAB and Octave), whole or not at all.

        Parameters
        ----------
        path : str or Path
            The .mat file.

        Returns
        -------
        Path
            The path.
        """
        from scipy.io import savemat

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        content: dict[str, object] = {"t": self.t.reshape(-1, 1)}
        for name, values in self.columns.items():
            content[name] = values.reshape(-1, 1)
        content["units"] = {k.replace(".", "_"): v for k, v in self.units.items()}
        content["meta"] = {k: v for k, v in self.meta.items() if isinstance(v, (int, float, str)) and k.isidentifier()}
        content["recording_json"] = json.dumps(self._sidecar())
        with atomic_path(path) as tmp:
            savemat(tmp, content, do_compression=True, oned_as="column")
        return path

    @classmethod
    def from_mat(cls, path, ts: float | None = None) -> Recording:
        """Read a .mat file written by :meth:`to_mat`, or any MATLAB file of named vectors or a struct
        (v5 or v7.3, see :mod:`porosense.data.matfile`).

        Parameters
        ----------
        path : str or Path
            The .mat file.
        ts : float or None
            Sample period, s, used when the file holds neither ``t`` nor ``Ts``.

        Returns
        -------
        Recording
            The recording; without a ``t`` variable the time axis is k * Ts.

        Raises
        ------
        InputError
            No such file, or no time axis and no sample period.
        """
        from scipy.io import loadmat

        from porosense.data.matfile import _is_hdf5, read_mat

        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such file")
        content: dict | None = {} if _is_hdf5(path) else None
        if content is None:
            try:
                content = loadmat(path)
            except Exception:  # not v5, or damaged: the general reader says which
                content = {}
        if "t" not in content or "recording_json" not in content:
            table = read_mat(path)
            step = ts or table.ts
            if "t" in table.columns:
                t = table.columns["t"]
            elif step:
                t = np.arange(len(table)) * float(step)
            else:
                raise InputError(f"{path}: no variable 't' (time in s) and no Ts: pass ts=SECONDS")
            cols = {k: v for k, v in table.columns.items() if k != "t"}
            return cls(t, cols, {"source": str(path)})
        sidecar = {}
        if "recording_json" in content:
            sidecar = json.loads(str(np.asarray(content["recording_json"]).ravel()[0]))
        order = sidecar.get("columns") or [
            k for k in content if not k.startswith("__") and k not in ("t", "units", "meta", "recording_json")
        ]
        dtypes = sidecar.get("dtypes", {})
        columns = {}
        for name in order:
            if name not in content:
                raise InputError(f"{path}: variable '{name}' is missing")
            values = np.asarray(content[name]).ravel()
            if name in dtypes:  # MATLAB has no bool: logical columns come back as uint8
                values = values.astype(np.dtype(dtypes[name]))
            columns[name] = values
        return cls(
            np.asarray(content["t"], dtype=float).ravel(), columns, sidecar.get("meta", {}), sidecar.get("units", {})
        )
