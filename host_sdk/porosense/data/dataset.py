"""``Dataset``: input and output signals with their sample period, names and units, like MATLAB's ``iddata``.

    data = Dataset(u, y, ts=0.02, input_names=["dR_0"], output_names=["strain_0"],
                   input_units=["%"], output_units=["%"])
    data = Dataset.from_file("run.csv", inputs=["dR_0"], outputs=["strain_0"])   # time base checked
    model = porosense.fit("wh", data, n_poles=4, n_zeros=2)
    porosense.compare(model, data); porosense.resid(model, data).plot()

``ts`` is in ``time_unit`` (s, ms or us), as iddata's ``Ts`` is in its ``TimeUnit``; ``ts_s`` is
the same period in seconds, which everything in porosense takes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from porosense.data.sampling import SECONDS_PER, unit_of
from porosense.errors import InputError


def _matrix(values, what: str) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise InputError(f"{what} must be a vector or an (N, k) matrix, not {a.ndim}-D")
    return a


@dataclass
class Dataset:
    """Signals of one experiment: ``u`` (N, n_u), ``y`` (N, n_y) or None, sampled every ``ts``.

    Parameters
    ----------
    u, y : array_like
        Inputs and outputs, one column per signal (vectors are one column). ``y`` may be None
        (data to predict from).
    ts : float
        Sample period in ``time_unit``.
    input_names, output_names : list of str
        Column names (default ``u1..``, ``y1..`` as iddata names them).
    input_units, output_units : list of str
        Units (default empty).
    time_unit : {'s', 'ms', 'us'}
        Unit of ``ts`` (also 'seconds', 'milliseconds', ... as MATLAB writes them).
    """

    u: np.ndarray
    y: np.ndarray | None
    ts: float
    input_names: list = field(default_factory=list)
    output_names: list = field(default_factory=list)
    input_units: list = field(default_factory=list)
    output_units: list = field(default_factory=list)
    time_unit: str = "s"

    def __post_init__(self):
        self.u = _matrix(self.u, "u")
        self.y = None if self.y is None else _matrix(self.y, "y")
        unit = unit_of(self.time_unit)
        if unit is None:
            raise InputError(f"time_unit {self.time_unit!r}: give s, ms or us")
        self.time_unit = unit
        ts = float(self.ts)
        if not (np.isfinite(ts) and ts > 0):
            raise InputError(f"ts {self.ts!r}: the sample period must be a positive number (in {unit})")
        self.ts = ts
        if self.y is not None and len(self.y) != len(self.u):
            raise InputError(f"u has {len(self.u)} samples, y {len(self.y)}: one record has one length")
        n_u, n_y = self.u.shape[1], 0 if self.y is None else self.y.shape[1]
        self.input_names = list(self.input_names) or [f"u{k + 1}" for k in range(n_u)]
        self.output_names = list(self.output_names) or [f"y{k + 1}" for k in range(n_y)]
        self.input_units = list(self.input_units) or [""] * n_u
        self.output_units = list(self.output_units) or [""] * n_y
        for what, names, units, n in (
            ("input", self.input_names, self.input_units, n_u),
            ("output", self.output_names, self.output_units, n_y),
        ):
            if len(names) != n or len(units) != n:
                raise InputError(f"{n} {what} column(s) but {len(names)} names and {len(units)} units")

    @property
    def ts_s(self) -> float:
        """The sample period in seconds."""
        return self.ts * SECONDS_PER[self.time_unit]

    @property
    def samples(self) -> int:
        return len(self.u)

    def __len__(self) -> int:
        return len(self.u)

    @property
    def time(self) -> np.ndarray:
        """Sample times from 0, in ``time_unit``."""
        return np.arange(len(self)) * self.ts

    def __getitem__(self, rows) -> Dataset:
        """The samples ``rows`` (a slice), as ``data(1:100)`` in MATLAB (0-based, end exclusive)."""
        if not isinstance(rows, slice) or rows.step not in (None, 1):
            raise InputError("select samples with a slice such as data[100:400]")
        return Dataset(
            self.u[rows],
            None if self.y is None else self.y[rows],
            self.ts,
            self.input_names,
            self.output_names,
            self.input_units,
            self.output_units,
            self.time_unit,
        )

    @classmethod
    def from_table(cls, table, inputs, outputs=()) -> Dataset:
        """Columns of a :class:`porosense.data.Table` (from ``load_data``) as a Dataset.

        Parameters
        ----------
        table : Table
            Columns with their stated period (``table.ts``, s) and units.
        inputs : sequence of str
            Input column names.
        outputs : sequence of str
            Output column names (empty: no outputs).

        Returns
        -------
        Dataset
            Sampled every ``table.ts`` s, with the table's units.

        Raises
        ------
        InputError
            A column missing, or a table without a sample period.
        """
        missing = [c for c in list(inputs) + list(outputs) if c not in table.columns]
        if missing:
            raise InputError(f"{table.path}: no column(s) {', '.join(missing)} (columns: {', '.join(table.names)})")
        if not table.ts:
            raise InputError(f"{table.path}: no time column and no stated period: build the Dataset with ts=")
        units = getattr(table, "units", {}) or {}
        return cls(
            np.column_stack([table.columns[c] for c in inputs]),
            np.column_stack([table.columns[c] for c in outputs]) if outputs else None,
            table.ts,
            list(inputs),
            list(outputs),
            [units.get(c, "") for c in inputs],
            [units.get(c, "") for c in outputs],
            "s",
        )

    @classmethod
    def from_file(cls, path, inputs, outputs=(), **read_options) -> Dataset:
        """Read a file with :func:`porosense.data.load_data` (time base checked) and take the columns.

        Parameters
        ----------
        path : str or Path
            A .mat file or a text table of any common dialect.
        inputs : sequence of str
            Input column names.
        outputs : sequence of str
            Output column names (empty: no outputs).
        **read_options
            Passed to ``load_data`` (``separator``, ``decimal``, ``time_unit``, ``resample``, ...).

        Returns
        -------
        Dataset
            Sampled at the file's period, s.

        Raises
        ------
        InputError
            An unreadable file, a bad time base, or a column missing.
        """
        from porosense.data.load import load_data

        return cls.from_table(load_data(path, **read_options), inputs, outputs)

    def __repr__(self) -> str:
        outs = f", outputs {self.output_names}" if self.y is not None else ""
        return f"Dataset({len(self)} samples, Ts {self.ts:g} {self.time_unit}, inputs {self.input_names}{outs})"

    def to_dict(self) -> dict:
        """The description without the signals.

        Returns
        -------
        dict
            Samples, ts (in ``time_unit``), time unit, names and units.
        """
        return {
            "samples": len(self),
            "ts": self.ts,
            "time_unit": self.time_unit,
            "input_names": self.input_names,
            "output_names": self.output_names,
            "input_units": self.input_units,
            "output_units": self.output_units,
        }

    def plot(self, path=None):
        """Every signal against time, one axis per signal, with its name and unit.

        Parameters
        ----------
        path : str or Path or None
            Also save the figure there (PNG, PDF, ...).

        Returns
        -------
        matplotlib Figure
            The figure.
        """
        import matplotlib.pyplot as plt

        signals = [(n, u, self.u[:, k]) for k, (n, u) in enumerate(zip(self.input_names, self.input_units))]
        if self.y is not None:
            signals += [(n, u, self.y[:, k]) for k, (n, u) in enumerate(zip(self.output_names, self.output_units))]
        fig, axes = plt.subplots(len(signals), 1, sharex=True, figsize=(8, 1.8 * len(signals)), squeeze=False)
        for ax, (name, unit, values) in zip(axes[:, 0], signals):
            ax.plot(self.time, values)
            ax.set_ylabel(f"{name} ({unit})" if unit else name)
        axes[-1, 0].set_xlabel(f"time ({self.time_unit})")
        fig.tight_layout()
        if path is not None:
            from porosense.files import save_figure

            save_figure(fig, path, dpi=110)
        return fig
