"""``porosense predict``: simulate a saved model on a recording, and score it when the output is there."""

from __future__ import annotations

import argparse

from porosense.cli._data import (
    add_column_options,
    add_data_options,
    add_json_options,
    bind_columns,
    emit_json,
    load_model_checked,
    model_period,
    normalise_json_args,
    output_file,
    read_tables,
    require_columns,
    say,
)
from porosense.errors import InputError, ModelError
from porosense.files import write_text


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "predict",
        help="simulate a saved model on a recording from rest; fit and RMS when the output is measured",
        description=(
            "Simulate an identified model (porosense identify --save) on the whole recording (CSV or "
            ".mat) from rest. When the file holds the model's output column, print the NRMSE fit (%) and "
            "the RMS error (% of the largest output) per output, as MATLAB's compare does. --out writes one "
            "column per output named <output>_pred in the output's unit, plus the time column (t, s) when "
            "the file has one; --plot draws measured against predicted. A model identified with "
            "--process-noise predicts the noise-free system (its static map g itself, what the board runs "
            "after quantize); --expected gives instead its output averaged over the estimated noise, the "
            "best match to a recording that carries that noise."
        ),
        epilog="example: porosense predict --model model.json --data step_20.csv --out pred.csv --plot pred.png",
    )
    p.add_argument("--model", required=True, metavar="MODEL.json", help="model file")
    p.add_argument(
        "--data", required=True, nargs="+", metavar="FILE", help="one CSV or .mat file with the model's input columns"
    )
    add_column_options(p)
    p.add_argument("--out", metavar="PRED.csv", help="write the predictions here (default: not written)")
    p.add_argument("--force", action="store_true", help="replace an existing --out")
    p.add_argument("--plot", metavar="FILE.png", help="plot measured and predicted output against time")
    p.add_argument(
        "--expected",
        action="store_true",
        help="for a model with process noise: the output averaged over the noise (default: noise-free)",
    )
    add_data_options(p, ts_help="sample period in s for the plot's time axis (default: the data's, else the model's)")
    add_json_options(p, "the scores and what was written")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import numpy as np

    from porosense.data import time_column
    from porosense.ident.scoring import format_percent, model_outputs, score_simulation

    normalise_json_args(args)
    if args.out:
        output_file(args.out, "--out", force=args.force)
    if args.plot:
        output_file(args.plot, "--plot")
    if len(args.data) != 1:
        raise InputError(f"--data names {len(args.data)} files; predict takes one (porosense compare scores many)")
    args.data = args.data[0]
    model = load_model_checked(args.model)
    (table,) = read_tables([args.data], args)
    ts = model_period([table], model, args)
    bind_columns([table], args, model.inputs, model_outputs(model) if args.output else (), model=model)
    require_columns(table, list(model.inputs))
    table.require_finite(list(model.inputs))
    u = np.column_stack([table.columns[c] for c in model.inputs])
    from porosense.ident import ModelSet

    if args.expected and not any(
        getattr(m, "spec", None) is not None and m.spec.g_noise
        for m in (model.models if isinstance(model, ModelSet) else [model])
    ):
        raise InputError(f"--expected: {args.model} has no process noise (identify --process-noise)")
    with np.errstate(all="ignore"):
        yhat = model.predict(u=u, expected=True) if args.expected else model.predict(u=u)
    yhat = yhat[:, None] if yhat.ndim == 1 else yhat
    if not np.all(np.isfinite(yhat)):
        raise ModelError(
            f"{args.model}: the simulation diverges on {args.data} "
            f"({int(np.sum(~np.isfinite(yhat)))} non-finite values)"
        )
    outputs = model_outputs(model)
    scores = {}
    measured = [o for o in outputs if o in table.columns and np.all(np.isfinite(table.columns[o]))]
    if measured:
        # The one fit every command prints (porosense.ident.simulation_fit): from rest, every sample.
        cols = [outputs.index(o) for o in measured]
        scored = score_simulation(yhat[:, cols], np.column_stack([table.columns[o] for o in measured]), measured)
        scores = {o: {"fit": scored.fit[o], "rms": scored.rms[o]} for o in measured}
    tcol = time_column(table)
    t = table.time if table.time is not None else np.arange(len(table)) * ts
    written = []
    if args.out:
        names = ([tcol] if tcol else []) + [f"{o}_pred" for o in outputs]
        cols = ([table.columns[tcol]] if tcol else []) + [yhat[:, j] for j in range(yhat.shape[1])]
        data = np.column_stack(cols)
        rows = [",".join(names)] + [",".join(repr(float(v)) for v in row) for row in data]
        write_text(args.out, "\n".join(rows) + "\n")
        written.append(str(args.out))
        say(args, f"{len(data)} samples of {', '.join(n for n in names if n.endswith('_pred'))} written to {args.out}")
    if args.plot:
        from porosense.report.figures import plot_compare

        plot_compare(
            t,
            {o: table.columns[o] for o in scores},
            {o: yhat[:, j] for j, o in enumerate(outputs)},
            label=model_label(model),
            units=table.units,
            title=f"{args.model} on {args.data}",
            path=args.plot,
        )
        written.append(str(args.plot))
        say(args, f"figure written to {args.plot}")
    for o, s in scores.items():
        say(
            args,
            f"{o}: fit {format_percent(s['fit'])}, RMS {format_percent(s['rms'])} of max |{o}| (simulated from rest)",
        )
    if not scores:
        say(args, f"{args.data} holds no measured {', '.join(outputs)}: no fit to report")
    if not written and not scores:
        say(args, "nothing written: give --out PRED.csv or --plot FILE.png")
    emit_json(
        {
            "model": str(args.model),
            "data": str(args.data),
            "samples": int(len(table)),
            "outputs": outputs,
            "scores": scores,
            "written": written,
        },
        args,
    )
    return 0


def model_label(model) -> str:
    """'wh 4p/2z' style label of a model or model set."""
    ms = getattr(model, "models", [model])
    kinds = sorted({m.kind for m in ms})
    return "/".join(kinds) + (f" {ms[0].n_poles}p/{ms[0].n_zeros}z" if len(ms) == 1 else "")
