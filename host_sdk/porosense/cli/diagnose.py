"""``porosense diagnose``: what a simulation or model gets wrong, why, the extension and its gain."""

from __future__ import annotations

import argparse

from porosense.cli._args import add_deprecated, columns, parse_range
from porosense.cli._data import (
    add_data_options,
    add_json_options,
    check_units,
    emit_json,
    load_model_checked,
    model_period,
    normalise_json_args,
    output_file,
    read_tables,
    require_columns,
    sample_period,
    say,
)
from porosense.errors import InputError, ModelError

STRUCTURES = ("linear", "hammerstein", "wiener", "wh")


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "diagnose",
        help="find what a simulation or model gets wrong, name the cause, extend it and measure the gain",
        description=(
            "Compare measured data with a calibrated simulation (--sim), an identified model (--model) "
            "or a baseline identified first (--baseline). Residual tests (autocorrelation, prewhitened "
            "input cross-correlation, Billings-Voon nonlinearity tests, level, direction, trend, spectral "
            "lines, condition columns, clipping, spikes) name the most likely causes from a fixed catalogue "
            "(static_nonlinearity, hysteresis, slow_relaxation, time_delay, drift, periodic_disturbance, "
            "load_dependence, saturation, cross_coupling, outliers, unmodelled_dynamics, or none). Dynamics "
            "first: the nominal model's fit on each file that holds validation records, whole (every sample "
            "simulated from rest: the number predict prints), then its fit on the validation records and the "
            "corrected model's (nominal + an adequate-order linear correction, when the data need one); "
            "unmodelled_dynamics, time_delay and slow_relaxation are judged against the nominal model, every "
            "other cause against the corrected one. Each extension is refitted on the estimation range; its "
            "gain is the fit difference on the validation range against that baseline, on the same samples. "
            "A cause is found when its test is significant, its evidence agrees with its name and its "
            "held-out gain is confirmed (one-sided 5 %); found causes are ranked by gain, the simplest "
            "extension winning among overlapping gains. --ts is the sample period in seconds; A:B are sample "
            "ranges (Python slices) applied to "
            "every file. Without ranges, several files split into estimation (all but the last) and "
            "validation (the last); one file splits 60/40."
        ),
        epilog=(
            "example: porosense diagnose --data run.csv --input p_cmd_0 --output dR_0 "
            "--sim contractor --condition load_g --json-out diag.json --out diag/\n"
            "then: porosense diagnose --data staircase.csv step_10.csv --validation-data step_40.csv --input p_cmd_0 "
            "--output dR_0 --sim contractor --params params.json --save-extended extended.json"
        ),
    )
    p.add_argument("--data", nargs="+", required=True, metavar="FILE", help="recordings: CSV or MATLAB .mat files")
    p.add_argument("--input", required=True, nargs="+", metavar="COL", help="input column(s) the model uses")
    p.add_argument("--output", required=True, nargs="+", metavar="COL", help="the measured output column (one)")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument(
        "--sim",
        metavar="ACTUATOR",
        help="calibrate this simulator (contractor, bending, 3dof) "
        "to the estimation range (inputs: commanded vacuum in kPa; the simulator is driven by all its "
        "channels' commands p_cmd_0.. when the files have them) and diagnose it; material: the "
        "piezoresistive law of --params (porosense calibrate material) on tensile records, --input the "
        "strain column (%% unless the file states 1), --output the resistance (ohm), each file's R0 and "
        "its drift taken from its estimation samples (a file given for validation only: all its samples), "
        "as 'simulate material --replay' does",
    )
    what.add_argument("--model", metavar="MODEL.json", help="diagnose a model saved by 'porosense identify'")
    what.add_argument(
        "--baseline",
        choices=STRUCTURES,
        metavar="STRUCTURE",
        help="identify a baseline of this structure (linear, hammerstein, wiener, wh) first",
    )
    p.add_argument(
        "--params",
        metavar="PARAMS.json",
        help="with --sim: the simulator's parameter file (porosense calibrate ACTUATOR, or one extended by "
        "--save-extended), its mean recording run as it is; without it, porosity, output scale and offset are "
        "calibrated to the estimation range. Either way, for a dR_ output every record (estimation and "
        "validation) gets its own recording state (sensitivity, contact-law scale, kinetics, softening, "
        "offset, R0 drift) fitted within the 99 %% interval of the simulator's stated recording-to-recording "
        "spread, reported per record",
    )
    p.add_argument(
        "--condition",
        nargs="*",
        default=[],
        metavar="COL",
        help="extra measured columns the model does not use (a load, other channels): a column in an input's "
        "unit is taken for another channel's command (tested for cross_coupling), one in another unit for a "
        "measured condition (tested for load_dependence); without a stated unit, for both",
    )
    p.add_argument("--estimation", metavar="A:B", help="sample range of every file used for estimation")
    p.add_argument("--validation", metavar="A:B", help="sample range of every file used for validation")
    p.add_argument(
        "--validation-data",
        nargs="+",
        metavar="FILE",
        help="separate validation files (then --data is estimation only)",
    )
    p.add_argument("--poles", type=int, default=2, help="baseline poles per input (default 2)")
    p.add_argument("--zeros", type=int, default=1, help="baseline zeros per input (default 1)")
    p.add_argument(
        "--alpha", type=float, default=0.01, help="family-wise false-alarm level over the catalogue (default 0.01)"
    )
    add_data_options(p)
    add_json_options(p, "the findings", legacy_path=True)
    p.add_argument("--out", metavar="DIR", help="write figures and a Markdown summary into DIR")
    add_deprecated(p, "--report", "--out", "out")
    p.add_argument(
        "--unit", metavar="UNIT", help="the output's unit on the figures (default: from the recording's sidecar)"
    )
    p.add_argument(
        "--save-extended",
        metavar="EXT.json",
        help="write the top cause's extension here. With --model or --baseline: a model file that "
        "'porosense predict' runs and, where the device structure carries it, 'quantize' and 'flash' take. "
        "With --sim and --params: the parameter file extended by the cause, its parameters fitted on the "
        "estimation records (which then need the dR_<channel> columns) and its gain measured on the "
        "validation records; 'porosense simulate --params' runs it. load_dependence is saved as the load "
        "taken from the recordings' load_g column (g, given with --condition), which 'simulate --replay' reads",
    )
    p.add_argument("--force", action="store_true", help="replace an existing --save-extended file")
    p.set_defaults(func=run)
    return p


def _column_kinds(conditions, inputs, tables) -> dict:
    """What each --condition column is, from the units the files state (or porosense's column
    conventions): in an input's unit, another channel's command or signal ("input", which
    cross_coupling tests); in another unit, a measured condition such as a load ("condition",
    which load_dependence tests); no unit stated, left to both."""
    from porosense.data.units import column_unit, normal_unit

    stated = [t.units for t in tables]
    input_units = {normal_unit(u) for u in (column_unit(c, *stated) for c in inputs) if u}
    kinds = {}
    for c in conditions:
        unit = column_unit(c, *stated)
        if unit and input_units:
            kinds[c] = "input" if normal_unit(unit) in input_units else "condition"
    return kinds


def _load(tables, inputs, output, conditions):
    """[(u (N, n_in), y (N,), {condition: (N,)})] per file; clear errors for absent columns."""
    import numpy as np

    out = []
    for table in tables:
        f = table.path
        require_columns(table, inputs + [output] + conditions)
        u = np.column_stack([table.columns[c] for c in inputs])
        y = np.asarray(table.columns[output], float)
        cond = {c: np.asarray(table.columns[c], float) for c in conditions}
        out.append((f, u, y, cond))
    return out


def _cut(item, rng, what):
    import numpy as np

    f, u, y, cond = item
    sl = rng if rng is not None else slice(None)
    u, y = u[sl], y[sl]
    cond = {k: v[sl] for k, v in cond.items()}
    if len(y) < 50:
        raise InputError(f"{f}: the {what} range leaves {len(y)} samples (need >= 50)")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y)) and all(np.all(np.isfinite(v)) for v in cond.values())):
        raise InputError(f"{f}: empty or non-finite cells in the selected columns of the {what} range")
    if np.ptp(y) == 0:
        raise InputError(f"{f}: the output is constant at {y[0]:g} over the {what} range: it has no fit to diagnose")
    return u, y, cond


def _parts(args, tables, vtables) -> list:
    """[(table, estimation slice or None, validation slice or None)] for every file, tables then
    vtables; None: the file has no such part. The one statement of the split: with
    --validation-data the --estimation range of every --data file and the --validation range of
    every --validation-data file; without ranges, several files: all but the last whole for
    estimation and the last whole for validation, one file: 60/40; with one range, the other is
    the rest of each file."""
    est_rng, val_rng = parse_range(args.estimation), parse_range(args.validation)
    whole = slice(None)
    if args.validation_data:
        return [(t, est_rng or whole, None) for t in tables] + [(t, None, val_rng or whole) for t in vtables]
    if est_rng is None and val_rng is None:
        if len(tables) > 1:
            return [(t, whole, None) for t in tables[:-1]] + [(tables[-1], None, whole)]
        cut = int(0.6 * len(tables[0]))
        return [(tables[0], slice(0, cut), slice(cut, None))]
    if val_rng is None:
        val_rng = slice(est_rng.stop, None) if est_rng.stop is not None else est_rng
    elif est_rng is None:
        est_rng = slice(None, val_rng.start) if val_rng.start else val_rng
    return [(t, est_rng, val_rng) for t in tables]


def _split(args, inputs, conditions, tables, vtables):
    """Estimation and validation lists of (u, y, conditions), cut as :func:`_parts` states."""
    parts = _parts(args, tables, vtables)
    data = _load([t for t, _, _ in parts], inputs, args.output, conditions)
    est = [_cut(d, e, "estimation") for d, (_, e, _) in zip(data, parts) if e is not None]
    val = [_cut(d, v, "validation") for d, (_, _, v) in zip(data, parts) if v is not None]
    return est, val


def _predicted(args, predict, u, y):
    """(``predict``'s prediction for one record, the record's recording state as the diagnosis
    refits it: porosense.diagnose.calibrate.StateColumns for --sim, else None, and the record's
    calibrated simulation: porosense.diagnose.calibrate.Simulation for --sim, else None). A --sim
    prediction appends the record's state to ``args.record_states`` (set by :func:`_predictor`)."""
    n = len(args.record_states)
    yhat = predict(u, y)
    state = args.record_states[-1] if len(args.record_states) > n else None
    return yhat, getattr(state, "columns", None), getattr(state, "simulation", None)


def _predictor(args, inputs, est, drives):
    """(u -> yhat for the diagnosis, the nominal model or None, a line describing what is diagnosed).

    The callable takes a record's inputs (with --sim: the commands that drive the simulator,
    ``drives`` of the estimation records, see :func:`_sim_drive_columns`) and measured output. A model's prediction starts
    settled at the record's rest level or from rest, whichever its first samples show
    (porosense.diagnose.predict_as_started), so that no start-up transient enters the diagnosis
    that is not in the data; the fit printed first is the model simulated from rest, as ``predict`` scores it
    (see :func:`_from_rest_fits`).
    """
    from porosense.diagnose import predict_as_started

    us = [u for u, _, _ in est]
    ys = [y for _, y, _ in est]
    args.record_states = []
    if args.sim:
        us = drives

    def with_state(cal):
        def predict(u, y):
            yhat, state = cal.predict_record(u, y, args.ts)
            args.record_states.append(state)
            return yhat

        return predict

    if args.sim and args.params:
        from porosense.diagnose.calibrate import as_calibrated

        physics, effects = args.sim_params
        return (
            with_state(as_calibrated(args.sim, args.output, physics, effects)),
            None,
            f"{args.sim} simulator of {args.params}"
            + (f" (effects: {', '.join(effects)})" if effects else "")
            + (", each record with its own recording state" if args.output.startswith("dR_") else ""),
        )
    if args.sim:
        from porosense.diagnose.calibrate import calibrate

        cal = calibrate(args.sim, args.output, us, ys, args.ts)
        return (
            with_state(cal),
            None,
            f"{args.sim} simulator calibrated on estimation: porosity {cal.porosity:.1f} %"
            + (" (at its bound: the print's parameters cannot follow the data)" if cal.porosity_at_bound else "")
            + ", scale "
            f"{cal.scale:.4g}, offset {cal.offset:.4g} (fit {cal.fit_estimation:.1f} %)"
            + (", each record with its own recording state" if args.output.startswith("dR_") else ""),
        )
    if args.model:
        from porosense import ident

        model = ident.load_model(args.model)
        if hasattr(model, "models"):
            match = [m for m in model.models if m.output == args.output]
            if not match:
                raise ModelError(f"{args.model} has no model for output '{args.output}' (outputs: {model.outputs})")
            model = match[0]
        if len(model.inputs) != len(inputs):
            raise ModelError(f"{args.model} takes {len(model.inputs)} inputs, --input gives {len(inputs)}")
        return (lambda u, y: predict_as_started(model, u, y), model, f"model {args.model} ({model.kind})")
    if not 0 <= args.zeros < max(args.poles, 1) or args.poles > 10:
        raise InputError("--poles must be 1..10 and --zeros smaller than --poles")
    from porosense import ident

    model = ident.make_model(args.baseline, n_poles=args.poles, n_zeros=args.zeros)
    model.fit(u=us, y=ys, ts=args.ts, inputs=inputs, output=args.output)
    return (
        lambda u, y: predict_as_started(model, u, y),
        model,
        f"{args.baseline} baseline with {args.poles} poles and {args.zeros} zeros identified on estimation",
    )


def run(args) -> int:
    from porosense.diagnose import Record, diagnose

    normalise_json_args(args, make_folder=True)
    inputs = columns(args.input, "input", args)
    outs = columns(args.output, "output", args)
    if len(outs) != 1:
        raise InputError(f"--output {' '.join(outs)}: diagnose takes one output column")
    args.output = outs[0]
    conditions = [c for c in args.condition if c not in inputs and c != args.output]
    if not 0 < args.alpha < 1:
        raise InputError("--alpha must be between 0 and 1")
    if args.params and not args.sim:
        raise InputError("--params is the simulator's parameter file: give it with --sim ACTUATOR")
    material = args.sim == MATERIAL
    if material:
        _check_material_args(args, inputs)
    if args.save_extended and args.sim and not args.params:
        raise InputError(
            "--save-extended with --sim extends a parameter file: give --params PARAMS.json "
            "(porosense calibrate ACTUATOR --data ... --out PARAMS.json)"
        )
    if args.save_extended:
        output_file(args.save_extended, "--save-extended", force=args.force)
    if args.params:
        args.sim_params = _load_sim_params(args.sim, args.params)
        from porosense.sim.calibrate import calibrated_load_column

        column = calibrated_load_column(args.params)
        if column is not None:
            say(
                args,
                f"--params {args.params} was calibrated with each record under its load (column '{column}', g); "
                "diagnosis runs it on the commands alone, unloaded",
            )
    tables = read_tables(args.data, args)
    vtables = read_tables(args.validation_data, args) if args.validation_data else []
    args.ts = sample_period(tables + vtables, args)
    if args.model:  # a model runs per sample: on data at another rate it simulates other dynamics
        checked = load_model_checked(args.model)
        model_period(tables + vtables, checked, args)
        subs = list(getattr(checked, "models", None) or [checked])
        if len(subs) > 1:
            subs = [m for m in subs if m.output == args.output]
        for m in subs:  # the data's stated units against the model's, column by column
            check_units(tables + vtables, m, {**dict(zip(m.inputs, inputs)), m.output: args.output})
    # the simulator's extension is fitted to every measured resistance column, not only the output
    measured = _sim_measured_columns(args, inputs) if args.save_extended and args.sim else []
    extra = [c for c in measured if c not in conditions and c not in inputs and c != args.output]
    args.sim_load_column = _sim_load_column(conditions, tables + vtables) if measured else None
    if material:  # the law runs over each whole file (its relaxation remembers), then is cut like the data
        extra.append(_material_prediction(args, inputs[0], tables, vtables))
    drive = _sim_drive_columns(args, inputs, tables + vtables) if args.sim and not material else []
    extra += [c for c in drive if c not in conditions + inputs + extra]
    est, val = _split(args, inputs, conditions + extra, tables, vtables)

    def drive_of(u, cond):  # the simulator's commands of a record (the inputs where nothing else drives it)
        return _drive_matrix(u, cond, inputs, drive)

    if material:
        predict, nominal, what = None, None, f"material law of {args.params}"
    else:
        predict, nominal, what = _predictor(args, inputs, est, [drive_of(u, c) for u, _, c in est])
    kinds = _column_kinds(conditions, inputs, tables + vtables)

    def record(u, y, cond):
        yhat, state, simulation = (
            (cond[MATERIAL_SIM], None, None) if material else _predicted(args, predict, drive_of(u, cond), y)
        )
        return Record(u, y, yhat, args.ts, {k: v for k, v in cond.items() if k not in extra}, kinds, state, simulation)

    records = [[record(u, y, cond) for u, y, cond in part] for part in (est, val)]
    result = diagnose(
        records[0], records[1], alpha=args.alpha, nominal=nominal if args.save_extended and not args.sim else None
    )
    doc = result.to_dict()
    extension, tried = None, []
    if args.save_extended and args.sim:
        names = _validation_names(args, tables, vtables, len(val))
        extension, tried = _extend_simulator(args, result, measured, est, val, names, drive_of)
        doc["extension"] = extension.to_dict() if extension is not None else None
        doc["extensions_tried"] = [e.to_dict() for e in tried]
    states = _record_states(args, tables, vtables)
    if states:
        doc["record_states"] = states
    rest = _from_rest_fits(nominal, _validation_files(args, tables, vtables), inputs, args.output)
    if rest:
        doc["nominal_from_rest"] = rest
    if not _all_finite(doc):
        raise InputError("the diagnosis holds non-finite numbers (NaN or inf): check --ts and the data")
    emit_json(doc, args)
    if args.out:
        from porosense.data.units import NOT_STATED, column_unit
        from porosense.diagnose import report

        unit = args.unit or column_unit(args.output, *(t.units for t in tables)) or NOT_STATED
        report.write_report(result, args.out, title=f"Diagnosis of {what}", unit=unit)
        page = _write_page(result, args.out, f"Diagnosis of {what}")
        say(args, f"report written to {page}")
    say(args, f"diagnosed: {what}")
    for st in states:
        say(args, f"recording state of {st['data']} ({st['part']}): {st['text']} (fit {st['fit']:.2f} %)")
    for r in rest:
        say(
            args,
            f"nominal model on {r['data']} (every sample, simulated from rest, as predict scores it): "
            f"fit {r['fit']:.2f} %, "
            f"RMS {r['rms']:.2f} %",
        )
    say(args, str(result))
    if args.save_extended and args.sim:
        _say_extension(args, result, extension, tried)
    elif args.save_extended:
        if result.extended is None:
            say(args, f"no cause found: nothing to extend, {args.save_extended} not written")
        else:
            result.extended.save(args.save_extended)
            top = result.findings[0]
            say(args, f"extended model ({top.cause}) written to {args.save_extended}; on the device: {top.on_device}")
    return 0


MATERIAL = "material"
MATERIAL_SIM = "R_sim (material law)"  # the law's resistance, carried beside the data while it is cut


def _check_material_args(args, inputs) -> None:
    """One line for what ``--sim material`` cannot take."""
    if not args.params:
        raise InputError(
            "diagnose --sim material compares tensile records with a calibrated law: give --params PARAMS.json "
            "(porosense calibrate material --data REC --strain COL --resistance COL --out PARAMS.json)"
        )
    if len(inputs) != 1:
        raise InputError(f"--input {' '.join(inputs)}: --sim material takes one input, the strain column")
    if args.save_extended:
        raise InputError(
            "--save-extended with --sim material: the material law is extended by recalibrating it "
            "(porosense calibrate material --ablation reports what each effect adds); give it without --save-extended"
        )


def _material_prediction(args, strain_col: str, tables, vtables) -> str:
    """Add the calibrated law's resistance (ohm) to every table as column :data:`MATERIAL_SIM`.

    The law runs over the whole file from rest at its first strain; the file's R0 and linear
    drift (ln R, least squares) come from its estimation samples: the --estimation range, the
    first 60 % of a single file split 60/40, every sample of a file used for estimation whole or
    of a file used for validation only (--validation-data, the last of several files)."""
    import numpy as np

    from porosense.cli.calibrate import strain_fraction, time_axis
    from porosense.sim.calibrate import simulate_material

    physics, _ = args.sim_params
    for table, est_rng, _ in _parts(args, tables, vtables):
        require_columns(table, [strain_col, args.output])
        n = len(table)
        strain = strain_fraction(table, strain_col)
        r = np.asarray(table.columns[args.output], float)
        if not (np.all(np.isfinite(strain)) and np.all(np.isfinite(r))) or np.any(r <= 0):
            raise InputError(
                f"{table.path}: --sim material needs finite strain and a positive resistance (ohm) "
                f"in '{args.output}' on every sample"
            )
        mask = np.zeros(n, bool)
        mask[est_rng if est_rng is not None else slice(None)] = True  # a validation-only file: all of it
        sim = simulate_material(physics, time_axis(table, args.ts), strain, r, mask)
        table.columns[MATERIAL_SIM] = np.asarray(sim["R_sim"], float)
    return MATERIAL_SIM


def _load_sim_params(actuator: str, path):
    """(physics, effects) of a simulator parameter file; one clear line when it is not one."""
    from pathlib import Path

    from porosense.sim.extend import load_params

    if not Path(path).is_file():
        raise InputError(f"--params {path}: no such file")
    from porosense.sim.effects import measured_load

    try:
        physics, effects = load_params(path)
    except (ValueError, TypeError, KeyError) as exc:
        raise ModelError(f"--params {path} is not a simulator parameter file ({exc})") from None
    measured = measured_load(effects)
    if measured is not None:
        raise InputError(
            f"--params {path} takes the load during a record from its column '{measured[0]}' (g; extended by "
            "load_dependence): diagnosis runs the simulator on the commands alone; give the file it was extended "
            f"from, or replay it: porosense simulate {actuator} --params {path} --replay REC"
        )
    return physics, effects


def _sim_drive_columns(args, inputs, tables) -> list:
    """The columns that drive the --sim actuator's channels, in channel order: its commands
    ``p_cmd_0`` .. ``p_cmd_{n-1}`` (kPa) when every file has them, as porosense records them (a
    segment's contractors move one another: simulated with one command alone, a segment misses
    its own mechanics, which then looks like a neighbour's leak); otherwise the --input columns
    (empty list: the inputs drive it)."""
    from porosense import sim

    n = sim.make_plant(args.sim, noise=False).n_channels
    names = [f"p_cmd_{c}" for c in range(n)]
    if names == inputs or not all(c in t.columns for t in tables for c in names):
        return []
    return names


def _drive_matrix(u, cond: dict, inputs: list, drive: list):
    """(N, channels) commands of one record: the ``drive`` columns from its inputs ``u`` and
    ``cond`` columns, or ``u`` itself when ``drive`` is empty."""
    import numpy as np

    if not drive:
        return u
    cols = {**dict(zip(inputs, np.asarray(u).T)), **cond}
    return np.column_stack([cols[c] for c in drive])


def _sim_measured_columns(args, inputs) -> list:
    """The simulator's resistance columns (dR_0 ..) for its channels: what an extension is fitted to."""
    from porosense import sim

    n = sim.make_plant(args.sim, noise=False).n_channels
    if len(inputs) > n:
        raise InputError(f"--input names {len(inputs)} columns; the {args.sim} has {n} channels (p_cmd in kPa)")
    return [f"dR_{c}" for c in range(n)]


def _sim_load_column(conditions, tables):
    """The --condition column the simulator's load_dependence extension takes the load from
    (porosense.sim.extend.LOAD_COLUMN), when given and in g (stated so, or no unit stated); else None."""
    from porosense.data.units import column_unit, normal_unit
    from porosense.sim.extend import LOAD_COLUMN

    if LOAD_COLUMN not in conditions:
        return None
    unit = column_unit(LOAD_COLUMN, *(t.units for t in tables))
    return LOAD_COLUMN if unit is None or normal_unit(unit) == "g" else None


def _extend_simulator(args, result, measured, est, val, val_names, drive_of):
    """(the parameter file extended by the best found cause, every extension tried):
    porosense.sim.extend.extend_best on the diagnosis' found causes; ``drive_of(u, conditions)``
    gives a record's commands to the simulator (kPa, channel order)."""
    import numpy as np

    from porosense.sim.calibrate import ActuatorRecord
    from porosense.sim.extend import LOAD_COLUMN, extend_best

    load = args.sim_load_column  # the measured load (g) the load_dependence extension runs on, or None

    def records(part, names):
        out = []
        for (u, y, cond), name in zip(part, names):
            cols = {**cond, args.output: y}
            dr = np.column_stack([cols[c] for c in measured])
            outputs = {} if args.output in measured else {args.output: y}
            out.append(ActuatorRecord(drive_of(u, cond), args.ts, dr, outputs, name=name, load_g=cols.get(load)))
        return out

    physics, effects = args.sim_params
    causes = [f.cause for f in result.findings if f.found]
    if "load_dependence" in causes and load is None:
        causes.remove("load_dependence")
        say(
            args,
            f"load_dependence found, but the simulator takes the load from a column '{LOAD_COLUMN}' in g "
            "(give it with --condition): not extended by it",
        )
    est_recs = records(est, [f"estimation {k}" for k in range(len(est))])
    return extend_best(args.sim, physics, causes, est_recs, records(val, val_names), effects=effects)


def _say_extension(args, result, extension, tried) -> None:
    from porosense.sim.extend import EXTENSIBLE

    for e in tried:
        say(args, f"simulator {e} (estimation {e.gain_estimation:+.2f})")
    if result.top == "none":
        say(args, f"no cause found: nothing to extend, {args.save_extended} not written")
    elif extension is None:
        found = ", ".join(f.cause for f in result.findings if f.found)
        say(
            args,
            f"no cause found ({found}) extends the simulator (extensible: {', '.join(EXTENSIBLE)}): "
            f"{args.save_extended} not written",
        )
    else:
        extension.save(args.save_extended)
        say(
            args,
            f"parameter file extended by {extension.cause} (the largest gain on the estimation records) written "
            f"to {args.save_extended}; held-out gain {extension.gain:+.2f} fit points",
        )


def _write_page(result, folder, title: str):
    """The diagnosis as one self-contained HTML page (and Markdown) beside its figures: the ranked
    causes with their fits (nominal first, then with the extension), the evidence and every figure."""
    from pathlib import Path

    from porosense.report.page import DataTable, Section, write_report

    rows = [
        [f.cause, f"{f.confidence:.2f}", f"{f.fit_before:.1f}", f"{f.fit_after:.1f}", f"{f.gain:+.1f}"]
        for f in result.findings
    ]
    table = DataTable(
        "Causes ranked (fits on the validation range, %)",
        ["cause", "confidence", "fit, nominal model", "fit, with the extension", "gain (points)"],
        rows,
    )
    evidence = "\n\n".join(f"{f.cause}: {f.evidence}" for f in result.findings[:3])
    figures = [Path(folder) / f"{n}.png" for n in ("correlations", "level_direction", "spectrum", "fits")]
    sections = [
        Section("Findings", evidence, tables=[table]),
        Section("Figures", "Residual tests and the validation fits.", figures=[f for f in figures if f.exists()]),
    ]
    _, page = write_report(folder, title, sections, intro=f"Most likely cause: {result.top}.", name="diagnosis")
    return page


def _record_states(args, tables, vtables) -> list:
    """Each record's recording state fitted by ``--sim``
    (porosense.diagnose.calibrate.Calibration.predict_record), named by its file and range:
    [{data, part, gain, scale, kinetics, conditioning, offset, drift, at_bound, fit, text}]."""
    fitted = getattr(args, "record_states", None)  # --sim (with or without --params)
    if not fitted or not args.output.startswith("dR_"):
        return []

    def name(t, rng):
        return str(t.path) if rng == slice(None) else f"{t.path} [{rng.start or ''}:{rng.stop or ''}]"

    parts = _parts(args, tables, vtables)
    names = [(name(t, e), "estimation") for t, e, _ in parts if e is not None]
    names += [(name(t, v), "validation") for t, _, v in parts if v is not None]
    return [{"data": n, "part": p, **s.to_dict(), "text": str(s)} for (n, p), s in zip(names, fitted)]


def _validation_names(args, tables, vtables, n: int) -> list:
    """A name per validation record: its file (and the range, when one file gives both parts)."""
    if args.validation_data:
        return [str(t.path) for t in vtables]
    if args.estimation is None and args.validation is None and len(tables) > 1:
        return [str(tables[-1].path)]
    rng = args.validation or "the validation range"
    return [f"{t.path} [{rng}]" for t in tables][:n]


def _validation_files(args, tables, vtables) -> list:
    """The files that hold the validation records (:func:`_parts`), to be scored whole."""
    return [t for t, _, v in _parts(args, tables, vtables) if v is not None]


def _from_rest_fits(model, files, inputs, output) -> list:
    """Per file holding validation records: the nominal model's fit and RMS (%) on the whole file,
    as every command prints them (porosense.ident.simulation_fit: simulated from rest, every
    sample), so that diagnose's first number is predict's for the same model and file. A file with
    empty or non-finite cells in the model's columns is left out (only a range of it is usable)."""
    if model is None:
        return []
    import numpy as np

    from porosense.ident import simulation_fit

    out = []
    for table in files:
        u = np.column_stack([np.asarray(table.columns[c], float) for c in inputs])
        y = np.asarray(table.columns[output], float)
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
            continue
        s = simulation_fit(model, u, y, outputs=[model.output])
        out.append({"data": str(table.path), "fit": float(s.fit[model.output]), "rms": float(s.rms[model.output])})
    return out


def _all_finite(value) -> bool:
    import math

    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(_all_finite(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(_all_finite(v) for v in value)
    return True
