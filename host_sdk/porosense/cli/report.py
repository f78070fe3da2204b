"""``porosense report``: the paper's figures and tables from your recordings and models."""

from __future__ import annotations

import argparse
from pathlib import Path

from porosense.cli._data import (
    add_column_options,
    add_data_options,
    add_json_options,
    bind_columns,
    check_units,
    emit_json,
    load_model_checked,
    model_period,
    normalise_json_args,
    read_tables,
    require_columns,
    say,
)
from porosense.errors import InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "report",
        help="the paper's figures and tables (fits, RMS, poles, hysteresis, nonlinearity, porosity) as HTML",
        description=(
            "Score every model on every recording and write an HTML page (report.html, self-contained) with "
            "Markdown beside it: reconstructions with each model's fit in the legend, fit and RMS bars per "
            "recording with mean and standard error, Table 1 (mean ± SE per model and output), Table S2 "
            "(poles and zeros), hysteresis loops with fits per direction, the identified nonlinearities "
            "fitted to a*exp(b*x), and, when the recordings state their porosity (sidecar), power laws "
            "C (1 - phi/100)^n of the hold averages over porosity per pressure and load (Table S1)."
        ),
        epilog="example: porosense report --data step_20.csv step_40.csv --model model.json --out report/",
    )
    p.add_argument("--data", nargs="+", required=True, metavar="FILE", help="recordings (CSV or .mat)")
    add_column_options(p)
    p.add_argument(
        "--model",
        nargs="+",
        required=True,
        metavar="MODEL.json",
        help="saved models, compared with each other (NAME=FILE names one)",
    )
    p.add_argument("--out", default="report", metavar="DIR", help="output folder (default report/)")
    p.add_argument("--pressure", metavar="COL", help="commanded pressure column in kPa (default p_cmd_0 if present)")
    p.add_argument(
        "--units",
        nargs="*",
        default=[],
        metavar="COL=UNIT",
        help="units of columns the recordings do not state, e.g. strain_0=%%",
    )
    p.add_argument("--title", default="porosense report", help="page title")
    add_data_options(p)
    add_json_options(p, "the scores and the files written")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.ident.scoring import model_outputs
    from porosense.report.user_report import write_user_report

    normalise_json_args(args)
    units = {}
    for item in args.units:
        if "=" not in item:
            raise InputError(f"--units {item!r}: write COL=UNIT")
        k, v = item.split("=", 1)
        units[k] = v
    models = {}
    for item in args.model:
        name, _, path = item.rpartition("=") if "=" in item else (None, "", item)
        model = load_model_checked(path)
        kind = "/".join(sorted({m.kind for m in getattr(model, "models", [model])}))
        stem = Path(path).stem
        label = name or (stem if stem == kind else f"{stem} ({kind})")
        if label in models:
            raise InputError(f"two models are named {label!r}: name them NAME=FILE")
        models[label] = model
    if len({tuple(m.inputs) for m in models.values()}) > 1:
        raise InputError("the models take different inputs; report models of one estimator together")
    tables = read_tables(args.data, args)
    for label, model in models.items():
        model_period(tables, model, args, what=f"model {label}")
    first = next(iter(models.values()))
    bind_columns(tables, args, first.inputs, model_outputs(first))
    for model in models.values():
        check_units(tables, model)
    for table in tables:
        require_columns(table, list(first.inputs))
    page = write_user_report(tables, models, args.out, units=units, pressure=args.pressure, title=args.title)
    say(args, f"report written to {page}")
    emit_json(
        {
            "html": str(page),
            "markdown": str(Path(page).with_suffix(".md")),
            "models": list(models),
            "files": [str(t.path) for t in tables],
        },
        args,
    )
    return 0
