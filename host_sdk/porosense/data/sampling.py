"""Time and sampling of a recording, checked once for every command: ``check_sampling``.

A wrong time base is the quietest way to a wrong model: a time column in ms read as s makes
every time constant 1000 times too long, a dropped or duplicated sample shifts everything after
it. So every table a command reads passes through :func:`check_sampling` (docs/cli.md):

- the time column's unit is taken from ``--time-unit``, the column's name (``t_ms``), a units
  row, the sidecar or a .mat ``units`` struct, or inferred from the plausible sample rate, and
  refused as ambiguous when both s and ms would be plausible;
- the stamps must increase; a repeated stamp, a step back, or a step off the median period by
  more than :data:`GAP_FACTOR` (a dropped or an extra sample) is refused in one line naming the
  worst step and its line, unless ``resample`` interpolates onto a uniform grid (and says so).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from porosense.errors import InputError

# Name of a time column -> the unit its name states (None: the name states no unit).
TIME_COLUMNS = {
    "t": None,
    "time": None,
    "Time": None,
    "t_s": "s",
    "time_s": "s",
    "Time_s": "s",
    "t_ms": "ms",
    "time_ms": "ms",
    "t_us": "us",
    "time_us": "us",
}
SECONDS_PER = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
UNIT_SPELLINGS = {
    "s": "s",
    "sec": "s",
    "secs": "s",
    "second": "s",
    "seconds": "s",
    "ms": "ms",
    "msec": "ms",
    "millisecond": "ms",
    "milliseconds": "ms",
    "us": "us",
    "µs": "us",
    "μs": "us",
    "usec": "us",
    "microsecond": "us",
    "microseconds": "us",
}
# Sample rates a recording plausibly has: the board samples at 10..135 Hz, lab recorders for
# soft actuators at 1 Hz to a kHz or two. A unit-less time column is read in the unit that puts
# its rate in this band; where both s and ms do (steps of 0.5 to 1) the unit is ambiguous.
PLAUSIBLE_RATE_HZ = (1.0, 2000.0)
# A step more than 1.5 periods is a dropped sample (a drop makes a step of 2); one below half a
# period an extra sample. Host-clock jitter within these bounds is accepted and reported.
GAP_FACTOR = 1.5
STATED_TS_TOLERANCE = 0.01  # a stated period (Ts, the sidecar's rate) this far from the time column's is refused
JITTER_REPORTED = 0.01  # relative standard deviation of the steps above which it is stated


def unit_of(text) -> str | None:
    """'s', 'ms' or 'us' for a unit as people write it ('[s]', '(ms)', 'seconds'), else None."""
    if text is None:
        return None
    word = str(text).strip().strip("[]()").strip().lower()
    return UNIT_SPELLINGS.get(word)


def time_column(table) -> str | None:
    """Name of the table's time column.

    Parameters
    ----------
    table : Table
        Columns as read.

    Returns
    -------
    str or None
        The first of ``t``, ``time``, ``Time``, ``t_s``, ``t_ms``, ``t_us``, ... (``TIME_COLUMNS``)
        the table holds, or None.
    """
    return next((c for c in TIME_COLUMNS if c in table.columns), None)


@dataclass
class Sampling:
    """How a table is sampled: the period, where it and the time unit came from, what was done.

    Attributes
    ----------
    path : str
        The file.
    samples : int
        Rows.
    ts : float or None
        Sample period, s (None when neither a time column nor a stated period exists).
    ts_source : str
        Where the period came from.
    time_column : str or None
        Name of the time column, if any.
    time_unit : str or None
        Its unit: ``"s"``, ``"ms"`` or ``"us"``.
    unit_source : str
        Why that unit (the column name, the units row, an option, ...).
    jitter : float
        Relative standard deviation of the time steps (0.01 = 1 %).
    resampled : str
        What resampling did, ``""`` when nothing.
    """

    path: str
    samples: int
    ts: float | None  # s
    ts_source: str = ""
    time_column: str | None = None
    time_unit: str | None = None  # s, ms or us
    unit_source: str = ""
    jitter: float = 0.0  # relative standard deviation of the time steps
    resampled: str = ""  # what --resample did, '' when nothing

    def describe(self) -> str:
        """One line: the time column, its unit and why, the period, anything done to the data.

        Returns
        -------
        str
            E.g. ``"run.csv: time from column 't' in s (...), Ts 20 ms (50 Hz)"``.
        """
        if self.ts is None:
            return f"{self.path}: no time column and no stated sample period"
        where = (
            f"column '{self.time_column}' in {self.time_unit} ({self.unit_source})"
            if self.time_column
            else self.ts_source
        )
        text = f"{self.path}: time from {where}, Ts {_period(self.ts)} ({1.0 / self.ts:.4g} Hz)"
        if self.jitter > JITTER_REPORTED:
            text += f", steps jitter by {100 * self.jitter:.1f} % (accepted: no step beyond {GAP_FACTOR:g} periods)"
        if self.resampled:
            text += f"; {self.resampled}"
        return text

    def to_dict(self) -> dict:
        """The fields as a plain dict.

        Returns
        -------
        dict
            JSON-ready (``file``, ``samples``, ``ts`` in s, their sources, ``jitter``, ``resampled``).
        """
        return {
            "file": self.path,
            "samples": self.samples,
            "ts": self.ts,
            "ts_source": self.ts_source,
            "time_column": self.time_column,
            "time_unit": self.time_unit,
            "unit_source": self.unit_source,
            "jitter": self.jitter,
            "resampled": self.resampled,
        }


def _period(ts: float) -> str:
    return f"{ts * 1000:.4g} ms" if ts < 1 else f"{ts:.4g} s"


def _stated_unit(table, name: str, time_unit: str | None) -> tuple[str | None, str]:
    """(unit, where it came from) for time column ``name``, without inference."""
    if time_unit is not None:
        unit = unit_of(time_unit)
        if unit is None:
            raise InputError(f"--time-unit {time_unit!r}: give s, ms or us")
        return unit, "--time-unit"
    if TIME_COLUMNS.get(name):
        return TIME_COLUMNS[name], "from its name"
    stated = (getattr(table, "units", None) or {}).get(name)
    if stated is not None:
        unit = unit_of(stated)
        if unit is None:
            raise InputError(f"{table.path}: the time column '{name}' is in {stated!r}; porosense reads s, ms or us")
        return unit, getattr(table, "units_source", "") or "as the file states"
    return None, ""


def _inferred_unit(path, name: str, step: float) -> tuple[str, str]:
    """The unit that puts a unit-less time column's median step at a plausible sample rate."""
    lo, hi = PLAUSIBLE_RATE_HZ
    fits = [u for u in ("s", "ms") if lo <= 1.0 / (step * SECONDS_PER[u]) <= hi]
    if len(fits) == 1:
        other = "ms" if fits[0] == "s" else "s"
        rate_other = 1.0 / (step * SECONDS_PER[other])
        return fits[0], f"inferred: steps of {step:g} {other} would be {rate_other:.4g} Hz"
    rates = ", ".join(f"{1.0 / (step * SECONDS_PER[u]):.4g} Hz in {u}" for u in ("s", "ms"))
    what = (
        "is ambiguous" if fits else f"gives no sample rate a recording has ({lo:g} Hz..{hi / 1000:g} kHz) in s or in ms"
    )
    raise InputError(
        f"{path}: the unit of time column '{name}' {what} (median step {step:g}: {rates}); pass --time-unit s, ms or us"
    )


def check_sampling(table, *, time_unit: str | None = None, resample: bool = False) -> Sampling:
    """Check and state the time base of ``table`` (a :class:`porosense.data.Table`), in place.

    Sets ``table.time`` (the time column in s, or None), ``table.ts`` and ``table.ts_source``
    (the period in s the file states), ``table.sampling`` (the returned :class:`Sampling`), and,
    with ``resample``, replaces the columns by their linear interpolation on a uniform grid.

    Parameters
    ----------
    table : porosense.data.Table
        The columns as read, with ``units`` (from a units row, sidecar or .mat) when stated.
    time_unit : {'s', 'ms', 'us'}, optional
        The time column's unit, overriding every other source.
    resample : bool
        Interpolate a record with gaps or repeated stamps onto a uniform grid instead of refusing it.

    Returns
    -------
    Sampling
        The period (s), its source, the time column and unit and their source, what was done.

    Raises
    ------
    InputError
        On an ambiguous time unit, stamps that repeat or go back, a gap or an extra sample
        (without ``resample``), or a non-finite time stamp; one line naming the file and line.
    """
    path = str(table.path)
    name = time_column(table)
    n = len(table)
    if n == 0:
        raise InputError(f"{path}: no data rows (a header only?; columns: {', '.join(table.names) or 'none'})")
    sampling = Sampling(path, n, getattr(table, "ts", None), getattr(table, "ts_source", "") or "")
    table.time = None
    if name is None or n < 2:
        _scale_stated_ts(table, sampling, time_unit)
        table.sampling = sampling
        return sampling
    raw = np.asarray(table.columns[name], dtype=float)
    bad = np.flatnonzero(~np.isfinite(raw))
    if bad.size:
        raise InputError(
            f"{path}: {table.line_of(int(bad[0]))}: time column '{name}' holds an empty or non-finite stamp"
        )
    steps = np.diff(raw)
    forward = steps[steps > 0]
    if forward.size == 0:
        raise InputError(f"{path}: time column '{name}' never increases")
    median = float(np.median(forward))
    unit, source = _stated_unit(table, name, time_unit)
    if unit is None:
        unit, source = _inferred_unit(path, name, median)
    scale = SECONDS_PER[unit]
    ts = median * scale
    sampling.time_column, sampling.time_unit, sampling.unit_source = name, unit, source
    problem = _worst_step(table, name, raw, steps, median, unit)
    if problem and problem[0] == "back":
        raise InputError(problem[1])
    if problem and not resample:
        raise InputError(problem[1] + "; pass --resample to interpolate onto a uniform grid")
    if problem:
        sampling.resampled = _resample(table, name, raw, scale, ts)
        raw = np.asarray(table.columns[name], dtype=float)
        steps = np.diff(raw)
    sampling.jitter = float(np.std(steps) / median) if steps.size > 1 else 0.0
    _agrees_with_stated(table, sampling, name, ts, time_unit)
    sampling.ts, sampling.ts_source = ts, f"the '{name}' column of {table.path.name}"
    table.ts, table.ts_source = ts, sampling.ts_source
    table.time = raw * scale
    table.sampling = sampling
    return sampling


def _agrees_with_stated(table, sampling: Sampling, name: str, ts: float, time_unit: str | None) -> None:
    """InputError when the file states a period (a .mat Ts, the sidecar's rate) more than
    STATED_TS_TOLERANCE away from its time column's: one of the two is wrong, and taking either
    without a word would be a guess."""
    stated = sampling.ts
    if not stated or not np.isfinite(stated) or stated <= 0:
        return
    unit = unit_of(time_unit) if time_unit is not None else unit_of(getattr(table, "time_unit", None))
    stated_s = stated * SECONDS_PER[unit] if unit else stated
    if abs(stated_s - ts) <= STATED_TS_TOLERANCE * ts:
        return
    raise InputError(
        f"{table.path}: time column '{name}' steps {ts * 1000:.4g} ms ({1 / ts:.4g} Hz) but "
        f"{sampling.ts_source or 'the file'} states {stated_s * 1000:.4g} ms ({1 / stated_s:.4g} Hz): "
        "correct the one that is wrong (or give the column's unit with --time-unit)"
    )


def _scale_stated_ts(table, sampling: Sampling, time_unit: str | None) -> None:
    """A period stated without a time column (a .mat Ts) in the unit the file or user gives."""
    unit = unit_of(time_unit) if time_unit is not None else unit_of(getattr(table, "time_unit", None))
    if time_unit is not None and unit is None:
        raise InputError(f"--time-unit {time_unit!r}: give s, ms or us")
    if sampling.ts and unit and unit != "s":
        sampling.ts *= SECONDS_PER[unit]
        sampling.ts_source += f" (in {unit})"
        table.ts, table.ts_source = sampling.ts, sampling.ts_source


def _worst_step(table, name, raw, steps, median, unit) -> tuple[str, str] | None:
    """('back'|'gap', one-line message) for the worst irregular step, or None when uniform."""
    path = str(table.path)
    back = np.flatnonzero(steps < 0)
    if back.size:
        k = int(back[0]) + 1
        return (
            "back",
            f"{path}: {table.line_of(k)}: time '{name}' goes back from {raw[k - 1]:g} to {raw[k]:g} {unit} "
            f"(samples out of order; {back.size} step{'s' if back.size > 1 else ''} back in all)",
        )
    repeated = np.flatnonzero(steps == 0)
    if repeated.size:
        k = int(repeated[0]) + 1
        return (
            "repeat",
            f"{path}: {table.line_of(k)}: time '{name}' repeats {raw[k]:g} {unit} "
            f"(a duplicated sample; {repeated.size} repeated stamp{'s' if repeated.size > 1 else ''})",
        )
    ratio = steps / median
    worst = int(np.argmax(np.abs(np.log(ratio))))
    if ratio[worst] > GAP_FACTOR:
        gaps = int(np.sum(ratio > GAP_FACTOR))
        return (
            "gap",
            f"{path}: {table.line_of(worst + 1)}: a gap of {steps[worst]:g} {unit} in time '{name}' "
            f"({ratio[worst]:.3g} periods of {median:g} {unit}: about {int(round(ratio[worst])) - 1} samples missing; "
            f"{gaps} gap{'s' if gaps > 1 else ''} in all)",
        )
    if ratio[worst] < 1.0 / GAP_FACTOR:
        extra = int(np.sum(ratio < 1.0 / GAP_FACTOR))
        return (
            "extra",
            f"{path}: {table.line_of(worst + 1)}: a step of {steps[worst]:g} {unit} in time '{name}', "
            f"{ratio[worst]:.2g} of the period {median:g} {unit} (an extra sample; {extra} short step{'s' if extra > 1 else ''})",
        )
    return None


def _resample(table, name: str, raw: np.ndarray, scale: float, ts: float) -> str:
    """Replace every column by its linear interpolation on t0 + k ts (s); say what was done.

    Repeated stamps are averaged first; the time column keeps its unit."""
    t_s = raw * scale
    order = np.argsort(t_s, kind="stable")
    stamps, first, counts = np.unique(t_s[order], return_index=True, return_counts=True)
    grid = stamps[0] + ts * np.arange(int(np.floor((stamps[-1] - stamps[0]) / ts + 1e-9)) + 1)
    new = {}
    for col, values in table.columns.items():
        v = np.asarray(values, dtype=float)[order]
        new[col] = np.interp(grid, stamps, np.add.reduceat(v, first) / counts)
    new[name] = grid / scale
    table.columns = new
    table.lines = None  # rows no longer match the file's lines
    parts = [f"resampled {len(raw)} samples onto {len(grid)} at {_period(ts)} by linear interpolation"]
    gaps = np.diff(stamps)
    if gaps.size and gaps.max() > GAP_FACTOR * ts:
        parts.append(f"largest gap filled {_period(float(gaps.max()))}")
    repeats = int(np.sum(counts > 1))
    if repeats:
        parts.append(f"{repeats} repeated stamp{'s' if repeats > 1 else ''} averaged")
    return ", ".join(parts)
