"""``porosense compare``: score a saved model on recordings, as MATLAB's ``compare`` does."""

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


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "compare",
        help="score a saved model on recordings: fit and RMS per file, mean and standard error",
        description=(
            "Simulate a saved model from rest on every recording (CSV or .mat) and print, per output, the "
            "NRMSE fit (%) and the RMS error (% of the largest |output|) of each file, then their mean and "
            "standard error (sample standard deviation / sqrt(n)). --plot draws measured against predicted "
            "for the first file. The files' sample period must agree with the model's."
        ),
        epilog="example: porosense compare --model model.json --data step_20.csv step_40.csv --plot compare.png",
    )
    p.add_argument("--model", required=True, metavar="MODEL.json", help="model file (porosense identify --save)")
    p.add_argument("--data", nargs="+", required=True, metavar="FILE", help="recordings with the model's columns")
    add_column_options(p)
    p.add_argument("--plot", metavar="FILE.png", help="plot measured and predicted for the first file")
    add_data_options(p, ts_help="sample period in s (default: the data's; checked against the model's)")
    add_json_options(p, "the scores")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.cli.predict import model_label
    from porosense.ident.scoring import model_outputs
    from porosense.report.analysis import compare

    normalise_json_args(args)
    if args.plot:
        output_file(args.plot, "--plot")
    model = load_model_checked(args.model)
    tables = read_tables(args.data, args)
    model_period(tables, model, args)
    bind_columns(tables, args, model.inputs, model_outputs(model), model=model)
    for table in tables:
        require_columns(table, list(model.inputs) + model_outputs(model))
    result = compare(model, tables, name=model_label(model))
    if args.plot:
        import numpy as np

        from porosense.report.figures import plot_compare

        t0 = tables[0]
        time = t0.time if t0.time is not None else np.arange(len(t0)) * model.ts
        pred = result.predictions[str(t0.path)]
        plot_compare(
            time,
            {o: t0.columns[o] for o in result.outputs},
            {o: pred[:, j] for j, o in enumerate(result.outputs)},
            label=model_label(model),
            units=t0.units,
            title=f"{args.model} on {t0.path}",
            path=args.plot,
        )
        say(args, f"figure written to {args.plot}")
    say(args, str(result))
    emit_json(result.to_dict(), args)
    return 0
