"""``porosense identify``: estimate a model from recordings (CSV or .mat) and save it."""

from __future__ import annotations

import argparse

from porosense.cli._args import add_deprecated, columns, parse_range, warn
from porosense.cli._data import (
    add_data_options,
    add_json_options,
    emit_json,
    normalise_json_args,
    output_file,
    read_tables,
    require_columns,
    sample_period,
    say,
)
from porosense.errors import InputError

MAX_POLES_UNFORCED = 20  # the paper searches up to 10; beyond 20 the grid takes hours

STRUCTURE_CHOICES = ("linear", "hammerstein", "wiener", "wh", "all")
CRITERION_CHOICES = ("fit", "aic", "bic")
COST_WARNING_S = 180  # a search estimated to run longer than this is announced, with ways to shorten it
SCHEDULER_TIMEOUT_S = 10  # seconds to reach a Dask scheduler


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "identify",
        help="identify a linear/Hammerstein/Wiener/Wiener-Hammerstein model from recordings (CSV or .mat)",
        description=(
            "Estimate discrete-time models (simulation error, jointly over every file, each file "
            "simulated from rest) of one or more output columns from up to 3 input columns of "
            "recordings: CSV of any common dialect or MATLAB .mat (v5, v7.3). Without --poles the paper's "
            "order search runs (poles 1..10, zeros < poles). Models are selected on data not used to "
            "estimate them: --validation (a range of every file), --validation-data (other files), or by "
            "default a hold-out (the last file when there are at least 3 files, else the last 25 % of every "
            "file); --criterion fit selects by the validation fit (candidates within one standard error are "
            "tied and the smallest is taken), aic/bic by the information criteria. A:B ranges (Python slices, applied to every file) choose the samples "
            "that are scored; each file is still simulated from its first sample. Fit and RMS are in %; "
            "--ts is the sample period in seconds, taken from the data's t column, sidecar or Ts when "
            "they state it."
        ),
        epilog=(
            "example: porosense identify --data step_10.csv step_60.csv --input dR_0 --output strain_0 "
            "--structure wh --poles 4 --zeros 2 --estimation 0:2000 --validation 2000: "
            "--out model.json --json-out report.json"
        ),
    )
    p.add_argument(
        "--data",
        nargs="+",
        required=True,
        metavar="FILE",
        help="recordings, one per file: CSV (any common dialect) or MATLAB .mat",
    )
    p.add_argument("--input", required=True, nargs="+", metavar="COL", help="input column names (1 to 3)")
    p.add_argument("--output", required=True, nargs="+", metavar="COL", help="output column name(s)")
    p.add_argument("--structure", choices=STRUCTURE_CHOICES, default="all", help="model structure (default all)")
    p.add_argument("--poles", type=int, metavar="N", help="number of poles (default: search 1..--max-poles)")
    p.add_argument("--zeros", type=int, metavar="N", help="number of zeros, < poles (default: search)")
    p.add_argument(
        "--max-poles",
        type=int,
        default=10,
        metavar="N",
        help=f"largest pole count searched (default 10; above {MAX_POLES_UNFORCED} needs --force)",
    )
    p.add_argument(
        "--force", action="store_true", help="allow searches beyond the stated limits; replace an existing --out"
    )
    p.add_argument("--breakpoints", type=int, default=10, metavar="N", help="PWL breakpoints (2..64, default 10)")
    p.add_argument("--delay", type=int, default=0, metavar="SAMPLES", help="input delay in samples (default 0)")
    p.add_argument("--starts", type=int, default=2, metavar="N", help="starts per nonlinear model (default 2)")
    p.add_argument("--estimation", metavar="A:B", help="sample range of every file used for estimation")
    p.add_argument("--validation", metavar="A:B", help="sample range of every file used for validation")
    p.add_argument(
        "--validation-data",
        nargs="+",
        metavar="FILE",
        help="separate CSV files used for validation only (like MATLAB's compare(val, m))",
    )
    p.add_argument(
        "--criterion",
        default="fit",
        metavar="|".join(CRITERION_CHOICES),
        help="selection criterion: fit (validation NRMSE fit, default), aic or bic",
    )
    p.add_argument(
        "--full-grid",
        action="store_true",
        help="estimate every structure at every order (default: linear orders first, then the "
        "nonlinear structures at the 2 best linear orders)",
    )
    p.add_argument(
        "--smoothness",
        default="auto",
        metavar="auto|WEIGHT",
        help="smoothness penalty on the breakpoint values: auto (default) refits the selected "
        "nonlinear model with weights 1e-4, 1e-3, 1e-2 and keeps the best on validation; "
        "a number fixes the weight (0: none)",
    )
    p.add_argument(
        "--monotone",
        action="store_true",
        help="constrain the static nonlinearities to be monotone (the paper's maps all are)",
    )
    p.add_argument(
        "--process-noise",
        action="store_true",
        help="after the search, the best Wiener and WH candidates are refitted with a Gaussian "
        "noise entering before the static nonlinearity (g learnt noise-free, not "
        "noise-smoothed); they are scored by their output averaged over that noise and each "
        "keeps the noise unless its output-error fit validates better by more than one "
        "standard error; the saved model predicts and quantizes as the "
        "noise-free system (predict --expected gives the averaged output). The noise level is "
        "measured from the differences between periods when a file repeats its input (at least "
        "2 whole periods of a periodic excitation), and a model that reproduces the measured "
        "period power at no level (beyond 2.58 standard errors, 1 %% two-sided) is "
        "rejected for its output-error fit, and so is one whose noise-free system the records "
        "do not determine (builds that fit them within the noise differ on it by more than the "
        "chosen one moved from its output-error fit); without repeats only the averaged output is fitted, which cannot "
        "tell the level (the report says which). When at least 4 files are realisations of one "
        "periodic excitation (random-phase multisines), the orders are ranked by their "
        "nonparametric best linear approximation instead of the validation data, which carry "
        "the same noise: linear orders by number of parameters until one is not refuted at "
        "1 %%, "
        "the nonlinear structures at that order",
    )
    p.add_argument(
        "--max-iter",
        type=int,
        default=200,
        metavar="N",
        help="function evaluations per refinement (default 200, as in the paper)",
    )
    p.add_argument("--jobs", type=int, metavar="N", help="worker processes of the order search (default: all cores)")
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:8786",
        help="run the order search's candidates on a Dask cluster (optional extra porosense[cluster]; "
        "same model as the local pool; docs/cluster.md)",
    )
    p.add_argument(
        "--decimate",
        type=int,
        default=1,
        metavar="N",
        help="decimate every file by N first, through an anti-alias filter (zero-phase FIR at the new "
        "Nyquist frequency): N times fewer samples, a model at 1/N of the data's rate (default 1: none)",
    )
    p.add_argument(
        "--out", default="model.json", metavar="MODEL.json", help="where to write the model (default model.json)"
    )
    add_deprecated(p, "--save", "--out", "out")
    add_data_options(p)
    add_json_options(p, "the search report", legacy_path=True)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    return p


def load_recordings(tables, inputs, outputs, rng: slice):
    """(inputs, outputs, skip) from the tables (porosense.data.load_data) for the sample range ``rng``.

    Each file is kept from its first sample to the end of the range, so that models simulate
    it from rest; ``skip`` is where the range starts (samples simulated but not scored), the
    same for every file (all files must be long enough).
    """
    import numpy as np

    us, ys, starts = [], [], []
    for table in tables:
        f = table.path
        require_columns(table, inputs + outputs)
        n = len(table)
        start, stop, _ = rng.indices(n)
        if stop - start < 10:
            raise InputError(
                f"{f}: the range {rng.start}:{rng.stop} leaves {max(stop - start, 0)} samples of {n} (need >= 10)"
            )
        table.require_finite(inputs + outputs, slice(0, stop), "selected range")
        u = np.column_stack([table.columns[c] for c in inputs])[:stop]
        y = np.column_stack([table.columns[c] for c in outputs])[:stop]
        us.append(u)
        ys.append(y)
        starts.append(start)
    if len(set(starts)) > 1:
        raise InputError("the sample range starts at different samples in different files (negative A?)")
    return us, ys, starts[0]


def data_units(tables, inputs, outputs):
    """(input units, output units) the first file's sidecar states: an input unit the model can
    carry ("%" or "dR/100") or None; an output unit as free text or None."""
    from porosense.structure import INPUT_UNITS

    units = getattr(tables[0], "units", {}) or {}
    ins = [units.get(c) if units.get(c) in INPUT_UNITS else None for c in inputs]
    return ins, [units.get(c) for c in outputs]


def run(args) -> int:
    from porosense import ident

    normalise_json_args(args)
    inputs = columns(args.input, "input", args)
    outputs = columns(args.output, "output", args)
    if len(inputs) > 3:
        raise InputError(f"{len(inputs)} input columns; at most 3")
    if set(inputs) & set(outputs):
        from porosense.ident.excitation import check_identifiable

        check_identifiable([], [], inputs, outputs)
    if args.max_poles > MAX_POLES_UNFORCED and not args.force:
        raise InputError(
            f"--max-poles {args.max_poles} searches beyond {MAX_POLES_UNFORCED} poles (hours of work); "
            "add --force to run it"
        )
    if args.max_poles < 1:
        raise InputError("--max-poles must be >= 1")
    if args.decimate < 1:
        raise InputError(f"--decimate must be >= 1, not {args.decimate}")
    if args.jobs is not None and args.jobs < 1:
        raise InputError(f"--jobs must be >= 1, not {args.jobs}")
    if args.jobs is not None and args.scheduler:
        raise InputError("give either --jobs (local worker processes) or --scheduler (a Dask cluster), not both")
    output_file(args.out, "--out", force=args.force)
    tables = read_tables(args.data, args)
    args.ts = sample_period(tables, args)
    if args.poles is not None and not 0 <= args.poles <= 10:
        raise InputError("--poles must be 0..10")
    if args.zeros is not None and args.poles is not None and args.zeros >= max(args.poles, 1):
        raise InputError("--zeros must be smaller than --poles")
    if not 2 <= args.breakpoints <= 64:
        raise InputError("--breakpoints must be 2..64")
    if args.criterion not in CRITERION_CHOICES:
        raise InputError(f"unknown --criterion '{args.criterion}'; choose from {', '.join(CRITERION_CHOICES)}")
    if args.max_iter < 1:
        raise InputError("--max-iter must be at least 1")
    if args.validation is not None and args.validation_data:
        raise InputError("give either --validation (a range) or --validation-data (files), not both")
    est_range = parse_range(args.estimation) or slice(None)
    validation, holdout = None, ""
    if args.validation is not None:
        est_u, est_y, est_skip = load_recordings(tables, inputs, outputs, est_range)
        validation = load_recordings(tables, inputs, outputs, parse_range(args.validation) or slice(None))
        holdout = f"validation: range {args.validation} of every file"
    elif args.validation_data:
        est_u, est_y, est_skip = load_recordings(tables, inputs, outputs, est_range)
        validation = load_recordings(read_tables(args.validation_data, args), inputs, outputs, slice(None))
        holdout = f"validation: {len(args.validation_data)} separate file(s)"
    else:
        est_u, est_y, est_skip = load_recordings(tables, inputs, outputs, est_range)
    from porosense.ident.excitation import check_identifiable

    check_identifiable(est_u, est_y, inputs, outputs)
    input_units, output_units = data_units(tables, inputs, outputs)
    structures = tuple(ident.KINDS) if args.structure == "all" else (args.structure,)
    poles = [args.poles] if args.poles is not None else range(1, args.max_poles + 1)
    zeros = [args.zeros] if args.zeros is not None else None
    options = ident.SearchOptions(
        structures=structures,
        poles=tuple(poles),
        zeros=tuple(zeros) if zeros is not None else None,
        n_breakpoints=args.breakpoints,
        delay=args.delay,
        starts=args.starts,
        max_nfev=args.max_iter,
        skip=est_skip,
        criterion=args.criterion,
        staged=args.poles is None and not args.full_grid,
        monotone=args.monotone,
        process_noise=args.process_noise,
        holdout=holdout,
    )
    options.order_grid()  # an empty grid fails here, before any work
    executor = _executor(args)
    reporter = CostReporter(args, outputs)
    try:
        found = ident.identify(
            u=est_u,
            y=est_y,
            ts=args.ts,
            validation=(validation[0], validation[1], [validation[2]] * len(validation[0])) if validation else None,
            options=options,
            inputs=inputs,
            outputs=outputs,
            input_unit=input_units,
            output_units=output_units,
            smoothness=args.smoothness,
            decimate_by=args.decimate,
            record_names=list(args.data),
            executor=executor,
            progress=reporter,
            log=lambda line: say(args, line),
        )
    finally:
        reporter.close()  # the bar's line is cleared before anything else prints
        if executor is not None and hasattr(executor, "close"):
            executor.close()  # a Dask client (a local pool is shut down by identify)
    for name, result, choice, model in zip(outputs, found.results, found.smoothness, found.models):
        say(args, f"{name}:")
        say(args, str(result))
        if choice is not None:
            say(args, str(choice))
        noise = _process_noise_line(model) if args.process_noise else None
        if noise:
            say(args, noise)
    for note in found.notes:
        say(args, note)
    found.save(args.out)
    say(args, f"model saved to {args.out}")
    report = {
        "files": list(args.data),
        "inputs": inputs,
        "outputs": outputs,
        "ts": found.ts,
        "estimation": args.estimation,
        "validation": args.validation,
        "validation_data": args.validation_data,
        "holdout": found.holdout,
        "criterion": args.criterion,
        "decimate": args.decimate,
        "scheduler": args.scheduler,
        "model": str(args.out),
        "notes": found.notes,
        "results": found.to_dict()["results"],
    }
    emit_json(report, args)
    return 0


def _executor(args):
    """The Dask client of --scheduler, a local pool of --jobs workers, or None (identify's own)."""
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise InputError(
                "--scheduler needs Dask distributed, an optional extra: pip install 'porosense[cluster]'"
            ) from None
        try:
            return Client(args.scheduler, timeout=SCHEDULER_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise InputError(f"cannot reach the Dask scheduler at {args.scheduler}: {exc}") from None
    if args.jobs:
        from porosense.ident.workers import local_pool

        return local_pool(args.jobs)
    return None


class CostReporter:
    """The search's progress for the command line: a progress bar (unless --quiet or --json) and,
    once the first candidates have told what a candidate costs, one warning line when the
    search will take longer than COST_WARNING_S, with the options that shorten it."""

    def __init__(self, args, outputs):
        from porosense.ident.search import ProgressBar  # numpy and scipy: not at --help time

        self.args, self.outputs = args, list(outputs)
        self.quiet = bool(args.quiet or args.json)
        self.warned = False
        self.bar = ProgressBar()

    def __call__(self, p) -> None:
        if p.eta_seconds is not None and not self.warned:
            self.warned = True
            if p.eta_seconds > COST_WARNING_S:
                warn("porosense identify", self._warning(p))
        if not self.quiet:
            self.bar(p)

    def close(self) -> None:
        self.bar.close()

    def _warning(self, p) -> str:
        import numpy as np

        from porosense.ident.search import duration_text

        args = self.args
        factor = max(2, int(np.ceil(p.eta_seconds / max(COST_WARNING_S, 1.0))))
        rate = 1.0 / (args.ts * args.decimate)
        more = f" for each of {len(self.outputs)} outputs" if len(self.outputs) > 1 else ""
        return (
            f"this search will take about {duration_text(p.eta_seconds)}{more} on {p.workers} worker(s) "
            f"(estimated from the first candidates); to shorten it: --decimate {factor * args.decimate} "
            f"(anti-alias filtered, {factor}x fewer samples; the model then runs at {rate / factor:g} Hz), "
            f"--max-poles {min(args.max_poles, 5)} (fewer orders), --structure wh (one structure), "
            "or --scheduler tcp://HOST:8786 (a Dask cluster)"
        )


def _process_noise_line(model) -> str | None:
    """One line on how the selected model's process-noise level was decided, or None."""
    spec = getattr(model, "spec", None)
    if spec is None or not spec.g_bp:
        return None  # no map g (a linear or Hammerstein model was selected)
    if not spec.g_noise:
        return "process noise: not in the selected model (its output-error fit validated better and was kept)"
    from porosense.ident.noise_level import CONSISTENCY_Z

    info = model.info.get("process_noise")
    if info and info.get("method", "").endswith("rejected"):
        return (
            f"process noise: rejected; at no level tried does the model reproduce the measured period "
            f"differences (simulated/measured power {info['power_ratio']:.3f}, standard error "
            f"{info['power_ratio_error']:.3f}; beyond {CONSISTENCY_Z:.2f} standard errors, 1 % two-sided), so the "
            "output-error fit is kept"
        )
    deconvolution = (info or {}).get("deconvolution")
    unit = f" {model.output_unit}" if getattr(model, "output_unit", None) else ""
    if info and info.get("method", "").endswith("undetermined"):
        d = deconvolution
        return (
            f"process noise: {info['sigma_per_spread']:.2f} x the spread of g's input, measured from {info['periods']}, "
            f"but the records do not determine the noise-free system: {d['tied_builds']} builds fit them within the "
            f"noise and their noise-free outputs differ by up to {d['spread'] * model.y_std:.3g}{unit} RMS, more than "
            f"the {d['correction'] * model.y_std:.3g}{unit} the chosen one moved from its output-error fit; the "
            "output-error fit is kept"
        )
    if info:
        colour = info.get("colour")
        tail = (
            f"; white noise at g's input {'does not explain' if colour['refuted'] else 'explains'} the colour of "
            f"the differences: misfit {colour['statistic']:.1f} on {colour['dof']} dof, p = {colour['p_value']:.2g}"
            if colour
            else ""
        )
        if deconvolution:
            tail += (
                f"; noise-free system determined: it moved {deconvolution['correction'] * model.y_std:.3g}{unit} RMS "
                f"from its output-error fit, more than the {deconvolution['spread'] * model.y_std:.3g}{unit} "
                f"between the {deconvolution['tied_builds']} builds that fit within the noise"
            )
        return (
            f"process noise: {info['sigma_per_spread']:.2f} x the spread of g's input, measured from "
            f"{info['periods']} (simulated/measured period power {info['power_ratio']:.3f}{tail})"
        )
    return (
        f"process noise: {model.process_noise_std:.3g} at g's input, from the averaged output only "
        "(no file repeats its input, so the level is not identifiable; see --help)"
    )
