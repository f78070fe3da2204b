"""What every data-driven subcommand shares: reading recordings, Ts, models, and JSON output.

The conventions (docs/cli.md):

- ``--json`` prints the command's result as JSON on stdout (and nothing else there);
- ``--json-out FILE`` (or ``--report FILE`` where a command names it so) writes it to a file;
- no output flag is mandatory; files go to a stated default;
- ``--data`` takes CSV (any common dialect) or MATLAB .mat files; ``--ts`` is optional when
  the data states its sample period, and must agree with it unless ``--ts-override``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from porosense.errors import InputError, ModelError
from porosense.files import write_text


def add_data_options(p, *, ts_help: str = "sample period in s (default: from the time column, sidecar or Ts)") -> None:
    """The options that say how to read recordings (docs/cli.md, "Reading data")."""
    p.add_argument("--ts", type=float, metavar="SECONDS", help=ts_help)
    p.add_argument(
        "--ts-override",
        action="store_true",
        help="use --ts even where it disagrees with the data's own time column or Ts (or with the model's period)",
    )
    p.add_argument(
        "--time-unit",
        choices=("s", "ms", "us"),
        help="unit of the time column (default: from its name, a units row, the sidecar, or inferred and stated)",
    )
    p.add_argument(
        "--resample",
        action="store_true",
        help="interpolate records with gaps or repeated time stamps onto a uniform grid (default: refuse them)",
    )
    p.add_argument("--separator", choices=(",", ";", "tab", "space"), help="CSV separator (default: detected)")
    p.add_argument("--decimal", choices=(".", ","), help="CSV decimal mark (default: detected)")
    p.add_argument(
        "--skip-rows", type=int, default=0, metavar="N", help="lines to skip before a CSV's header (default 0)"
    )


def add_column_options(p, *, outputs: bool = True) -> None:
    """--input COL... and --output COL...: the data columns that stand for the model's inputs and outputs."""
    p.add_argument(
        "--input",
        nargs="+",
        metavar="COL",
        help="the data columns fed to the model's inputs, in order (default: the model's input names)",
    )
    if outputs:
        p.add_argument(
            "--output",
            nargs="+",
            metavar="COL",
            help="the data columns holding the measured outputs, in order (default: the model's output names)",
        )


def add_json_options(p, what: str = "the result", *, legacy_path: bool = False) -> None:
    """--json (stdout) and --json-out FILE.

    ``legacy_path``: the command once took ``--json FILE``; a file name after --json still
    writes there (as --json-out), so existing scripts keep working.
    """
    if legacy_path:
        p.add_argument(
            "--json",
            nargs="?",
            const=True,
            default=False,
            metavar="FILE",
            help=f"print {what} as JSON on stdout",
        )
    else:
        p.add_argument("--json", action="store_true", help=f"print {what} as JSON on stdout")
    p.add_argument("--json-out", metavar="FILE.json", help=f"write {what} as JSON to this file")


def normalise_json_args(args, make_folder: bool = False) -> None:
    """Fold a legacy ``--json FILE`` into ``--json-out FILE``; check (or make) its folder."""
    value = getattr(args, "json", False)
    if isinstance(value, str):
        if getattr(args, "json_out", None):
            raise InputError("give the JSON file once: --json-out FILE")
        from porosense.cli._args import deprecation

        deprecation(f"porosense {getattr(args, 'command', '')}".strip(), "--json FILE", "--json-out FILE")
        args.json_out, args.json = value, False
    if getattr(args, "json_out", None):
        if make_folder:
            Path(args.json_out).parent.mkdir(parents=True, exist_ok=True)
        output_file(args.json_out, "--json-out")


def read_tables(files, args):
    """Tables of ``files`` read with the data options of ``args``, each one's time base checked
    (porosense.data.check_sampling) and stated in one line per distinct finding."""
    from porosense.data import load_data

    sep = {"tab": "\t", "space": " "}.get(getattr(args, "separator", None), getattr(args, "separator", None))
    tables = [
        load_data(
            f,
            separator=sep,
            decimal=getattr(args, "decimal", None),
            time_unit=getattr(args, "time_unit", None),
            resample=getattr(args, "resample", False),
            skip_rows=getattr(args, "skip_rows", 0) or 0,
        )
        for f in files
    ]
    _state_sampling(tables, args)
    return tables


def _state_sampling(tables, args) -> None:
    """State the time base: one line per group of files read alike, every resampled file on its own."""
    groups: dict = {}
    for table in tables:
        s = table.sampling
        if s is None:
            continue
        key = (
            id(s)
            if s.resampled
            else (
                s.time_column,
                s.time_unit,
                s.unit_source,
                s.ts_source if not s.time_column else "",
                round(s.ts or 0, 12),
            )
        )
        groups.setdefault(key, []).append(s)
    for members in groups.values():
        more = len(members) - 1
        say(args, members[0].describe() + (f" (and {more} more file{'s' if more > 1 else ''} alike)" if more else ""))


def sample_period(tables, args) -> float:
    """The Ts (s) for ``tables``: the data's own, checked against --ts (see porosense.data.resolve_ts)."""
    from porosense.data import resolve_ts

    ts = resolve_ts(tables, getattr(args, "ts", None), getattr(args, "ts_override", False))
    given = getattr(args, "ts", None)
    if given is not None and not any(t.ts for t in tables):
        warn_implausible_ts(args, float(given))
    return ts


def warn_implausible_ts(args, ts: float) -> None:
    """One warning line when --ts (s) gives data without a time base a rate no recording plausibly
    has (porosense.data.sampling.PLAUSIBLE_RATE_HZ): most often a period written in ms."""
    from porosense.cli._args import warn
    from porosense.data.sampling import PLAUSIBLE_RATE_HZ

    lo, hi = PLAUSIBLE_RATE_HZ
    if ts > 0 and not lo <= 1.0 / ts <= hi:
        warn(
            f"porosense {getattr(args, 'command', None) or ''}".strip(),
            f"--ts {ts:g} s is a rate of {1.0 / ts:.4g} Hz, outside the {lo:g} Hz..{hi / 1000:g} kHz of a "
            f"recording: --ts takes seconds ({ts:g} ms is --ts {ts / 1000:g})",
        )


def model_period(tables, model, args, what: str = "the model") -> float:
    """The Ts (s) to run ``model`` on ``tables``: the data's own (checked against --ts) when they state
    one, else the model's (and the command says so); a data period more than 1 % off the model's is an
    InputError unless --ts-override (a model runs per sample: on data at another rate it simulates the
    wrong dynamics). ``model`` is anything with ``ts`` (s): a model, a model set, a blob."""
    model_ts = float(model.ts)
    if not (getattr(args, "ts", None) or any(t.ts for t in tables)):
        names = ", ".join(str(t.path) for t in tables)
        say(
            args,
            f"{names}: no time column and no stated period: taking {what}'s {model_ts * 1000:.4g} ms "
            f"({1 / model_ts:.4g} Hz); pass --ts if the data were sampled otherwise",
        )
        return model_ts
    ts = sample_period(tables, args)
    if abs(ts - model_ts) > 0.01 * model_ts and not getattr(args, "ts_override", False):
        raise InputError(
            f"the data's sample period {ts * 1000:.4g} ms ({1 / ts:.4g} Hz) differs from {what}'s "
            f"{model_ts * 1000:.4g} ms ({1 / model_ts:.4g} Hz): resample the data to the model's rate, "
            "or add --ts-override"
        )
    return ts


def bind_columns(tables, args, inputs, outputs=(), model=None) -> None:
    """Give the data columns named by ``--input``/``--output`` the model's names, in order (docs/cli.md).

    Without the options the model's own names are used as they are; with them, each table gets
    the model's input (output) names as copies of the named columns, so that everything after
    reads the model's names. With ``model``, a unit the data state for one of its signals must be
    the unit the model states for it (:func:`check_units`)."""
    from porosense.cli._args import columns

    for option, names in (("input", list(inputs)), ("output", list(outputs))):
        given = getattr(args, option, None)
        if not given:
            continue
        cols = columns(given, option, args)
        if len(cols) != len(names):
            raise InputError(
                f"--{option} names {len(cols)} column{'s' if len(cols) > 1 else ''}; the model has "
                f"{len(names)} {option}{'s' if len(names) != 1 else ''} ({', '.join(names)})"
            )
        for table in tables:
            require_columns(table, cols)
            for model_name, data_name in zip(names, cols):
                table.columns[model_name] = table.columns[data_name]
                if data_name in table.units:
                    table.units[model_name] = table.units[data_name]
    if model is not None:
        check_units(tables, model)


# Units of dR a model may state, converted where data meet it (quantize --input-unit, fit(input_unit=)).
_DR_UNITS = {"%", "dR/100"}


def model_units(model) -> dict:
    """{signal name: unit} of what ``model`` states: an identified model or model set, or an
    estimator structure (a blob states none)."""
    units: dict = {}
    for m in list(getattr(model, "models", None) or [model]):
        for name, unit in zip(getattr(m, "inputs", ()) or (), getattr(m, "input_units", ()) or ()):
            if unit:
                units[str(name)] = str(unit)
        output, unit = getattr(m, "output", None), getattr(m, "output_unit", None)
        if isinstance(output, str) and unit:
            units[output] = str(unit)
        for out, unit in zip(getattr(m, "outputs", ()) or (), getattr(m, "output_units", ()) or ()):
            name = out if isinstance(out, str) else getattr(out, "name", None)
            if name and unit:
                units[str(name)] = str(unit)
    return units


def check_units(tables, model, columns=None) -> None:
    """InputError when a table states a unit for one of the model's signals (a units row, the
    sidecar, a .mat units struct) other than the unit the model states for it: a model in % strain
    scored on strain in mm, or fed a resistance in ohms, gives a number without meaning.
    ``columns`` maps a model signal to the data column that feeds it (default: the same name)."""
    from porosense.data.units import normal_unit

    stated = model_units(model)
    columns = columns or {}
    for table in tables:
        for name, unit in stated.items():
            column = columns.get(name, name)
            data = (getattr(table, "units", None) or {}).get(column)
            if (
                not data
                or normal_unit(data) == normal_unit(unit)
                or {normal_unit(data), normal_unit(unit)} <= _DR_UNITS
            ):
                continue
            raise InputError(
                f"{table.path}: column {column} is in {data}, the model's {name} in {unit}: "
                "convert the data to the model's unit (or name another column with --input/--output)"
            )


def require_columns(table, names) -> None:
    """InputError naming the absent columns (and why a .mat variable of that name was left out)."""
    missing = [n for n in names if n not in table.columns]
    skipped = [n for n in missing if n in (getattr(table, "skipped", None) or {})]
    if skipped:
        n = skipped[0]
        raise InputError(f"{table.path}: variable '{n}' {table.skipped[n]}")
    if missing:
        raise InputError(
            f"{table.path}: no column{'s' if len(missing) > 1 else ''} "
            f"{', '.join(repr(m) for m in missing)} "
            f"(columns: {_names(table.names)}; read as {table.dialect})"
        )


def _names(names, shown: int = 20) -> str:
    """Column names for a one-line message: the first ``shown`` of a wide file, then the count."""
    names = list(names)
    return ", ".join(names) if len(names) <= shown else ", ".join(names[:shown]) + f", ... ({len(names):,} columns)"


def blob_checked(path, data: bytes, **limits):
    """``data`` (read from ``path``) parsed as a model blob as the board parses it; ModelError naming
    the file otherwise, and saying so when it is a model file (JSON) that was not quantized."""
    from porosense.protocol.model_blob import ModelBlob

    if data.lstrip()[:1] in (b"{", b"["):
        raise ModelError(
            f"{path} is a model file (JSON), not a blob: quantize it first (porosense quantize --model {path})"
        )
    try:
        return ModelBlob.from_bytes(data, **limits)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from None


def load_model_checked(path):
    """A saved model, refused (ModelError) when any coefficient is not finite.

    An extended model (a nominal model plus terms the device cannot run) is checked through its
    nominal model and its own coefficients, a series-compensated one through both its models."""
    from porosense.data.model_file import read_model_document
    from porosense.ident import load_model
    from porosense.ident.models import FORMAT_VERSION

    read_model_document(path)  # size, depth, NaN/inf and field types before anything is built
    model = load_model(path)
    try:  # the file's inner models carry their own format version
        inner = [d.get("version") for d in json.loads(Path(path).read_text()).get("models", [])]
    except (ValueError, AttributeError, OSError):
        inner = []
    bad = [v for v in inner if v != FORMAT_VERSION]
    if bad:
        raise ModelError(f"{path}: inner model format version {bad[0]}, this build reads {FORMAT_VERSION}")
    nominal = getattr(model, "nominal", None)
    _check_blocks_finite(path, nominal if nominal is not None else model)
    if getattr(model, "series", None) is not None:  # a series-compensated model: its block too
        _check_blocks_finite(path, model.series)
    if nominal is not None and not all(math.isfinite(float(c)) for c in getattr(model, "coef", ())):
        raise ModelError(f"{path}: the {model.cause} extension has non-finite (NaN or inf) coefficients")
    return model


def _check_blocks_finite(path, model) -> None:
    import numpy as np

    try:
        structure = model.to_structure()
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise ModelError(f"{path}: the model's blocks cannot be built ({exc})") from None
    for out in structure.outputs:
        blocks = [out.g, out.h2] + [b for br in out.branches for b in (br.f, br.h1)]
        values = [
            np.asarray(getattr(b, a)) for b in blocks if b is not None for a in ("x", "y", "sos") if hasattr(b, a)
        ]
        if not all(np.all(np.isfinite(v)) for v in values) or not math.isfinite(out.offset):
            raise ModelError(f"{path}: output '{out.name}' has non-finite (NaN or inf) coefficients")


def output_file(path, what: str = "output", *, force: bool | None = None) -> Path:
    """``path`` as a Path whose folder exists (InputError otherwise); with ``force`` given (the
    command's --force), a file already there is kept unless it is True."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what} {path} is a folder; give a file name")
    if not path.parent.is_dir():
        raise InputError(f"{what} {path}: the folder {path.parent} does not exist")
    if force is False and path.exists():
        raise InputError(f"{path} exists: --force replaces it")
    return path


def emit_json(doc, args) -> None:
    """Print ``doc`` on stdout with --json and write it to --json-out; floats as plain numbers,
    a NaN or infinite value as null (JSON has no NaN: strict parsers refuse the token)."""
    normalise_json_args(args)
    text = json.dumps(_finite(doc), indent=1, default=_plain, allow_nan=False)
    if getattr(args, "json_out", None):
        write_text(output_file(args.json_out, "--json-out"), text + "\n")
    if getattr(args, "json", False):
        sys.stdout.write(text + "\n")


def _finite(value):
    """``value`` with every non-finite float (NaN, inf) replaced by None, arrays as lists."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if type(value).__module__ == "numpy":
        return _finite(_plain(value))
    return value


def _plain(value):
    try:
        import numpy as np

        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, np.generic):
            return value.item()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(value, Path):
        return str(value)
    return float(value)


def say(args, text: str) -> None:
    """Human-readable text: stdout normally, stderr when stdout carries --json."""
    print(text, file=sys.stderr if getattr(args, "json", False) is True else sys.stdout)
