"""``porosense compensate``: a series transfer function for a load, after a model identified without it."""

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
from porosense.errors import InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "compensate",
        help="identify a series transfer function that compensates a load after a no-load model",
        description=(
            "The paper's load compensation: a model identified without load (porosense identify --out) "
            "loses fit under a load; a linear transfer function identified for the load condition and "
            "placed after it, from the model's simulated output to the output measured under the load, "
            "brings the fit back (paper, contractor under 500 g: 82.6 % without load, 61.7 % under it, "
            "74.07 % compensated). The no-load model is kept as it is; the series block is fitted on the "
            "--data records (simulation error, each file from rest) and every file given is scored without "
            "and with it: NRMSE fit and RMS error (% of the largest output), --validation-data files "
            "marked as held out. --out writes the compensated model, which porosense predict and compare "
            "read like any model file."
        ),
        epilog=(
            "example: porosense compensate --model model.json --data staircase_500g.csv step_10_500g.csv "
            "step_60_500g.csv --validation-data step_20_500g.csv step_40_500g.csv --condition '500 g' "
            "--out model_500g.json"
        ),
    )
    p.add_argument("--model", required=True, metavar="MODEL.json", help="the model identified without the load")
    p.add_argument(
        "--data", required=True, nargs="+", metavar="FILE", help="records under the load, used to fit the series block"
    )
    p.add_argument(
        "--validation-data", nargs="+", default=[], metavar="FILE", help="records under the load, only scored"
    )
    p.add_argument("--poles", type=int, default=2, metavar="N", help="poles of the series block (default 2)")
    p.add_argument("--zeros", type=int, default=1, metavar="N", help="zeros of the series block, < poles (default 1)")
    p.add_argument("--condition", default="", metavar="TEXT", help="what the block compensates, e.g. '500 g'")
    p.add_argument("--out", metavar="COMPENSATED.json", help="write the compensated model here (default: not written)")
    p.add_argument("--force", action="store_true", help="replace an existing --out")
    add_column_options(p)
    add_data_options(p)
    add_json_options(p, "the fits without and with the series block")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import numpy as np

    from porosense.ident import Model
    from porosense.ident.scoring import format_percent
    from porosense.ident.series import fit_series

    normalise_json_args(args)
    if args.out:
        output_file(args.out, "--out", force=args.force)
    if args.poles < 1 or not 0 <= args.zeros < args.poles:
        raise InputError(f"--poles {args.poles} --zeros {args.zeros}: need poles >= 1 and 0 <= zeros < poles")
    nominal = load_model_checked(args.model)
    if not isinstance(nominal, Model):
        raise InputError(
            f"{args.model}: a {nominal.kind} model; compensate takes one identified model of one output "
            "(porosense identify with one --output)"
        )
    files = list(args.data) + list(args.validation_data)
    tables = read_tables(files, args)
    ts = model_period(tables, nominal, args)
    bind_columns(tables, args, nominal.inputs, [nominal.output] if args.output else (), model=nominal)
    cols = list(nominal.inputs) + [nominal.output]
    for table in tables:
        require_columns(table, cols)
        table.require_finite(cols)
    us = [np.column_stack([t.columns[c] for c in nominal.inputs]) for t in tables]
    ys = [np.asarray(t.columns[nominal.output], dtype=float) for t in tables]
    n_est = len(args.data)
    with np.errstate(all="ignore"):
        model = fit_series(
            nominal, us[:n_est], ys[:n_est], ts=ts, order=(args.poles, args.zeros), condition=args.condition
        )
        before = nominal.score(u=us, y=ys)
        after = model.score(u=us, y=ys)
    rows = []
    for k, path in enumerate(files):
        role = "estimation" if k < n_est else "validation"
        rows.append(
            {
                "file": str(path),
                "role": role,
                "fit_nominal": before["fit"][k],
                "rms_nominal": before["rms"][k],
                "fit": after["fit"][k],
                "rms": after["rms"][k],
            }
        )
        say(
            args,
            f"{path} ({role}): fit {format_percent(before['fit'][k])} -> {format_percent(after['fit'][k])}, "
            f"RMS {format_percent(before['rms'][k])} -> {format_percent(after['rms'][k])}",
        )

    def mean(key, role=None):
        vals = [r[key] for r in rows if role is None or r["role"] == role]
        return float(np.mean(vals)) if vals else None

    summary = {
        "all": {k: mean(k) for k in ("fit_nominal", "rms_nominal", "fit", "rms")},
        "validation": {k: mean(k, "validation") for k in ("fit_nominal", "rms_nominal", "fit", "rms")}
        if args.validation_data
        else None,
    }
    label = f" for {args.condition}" if args.condition else ""
    for name, s in summary.items():
        if s is None:
            continue
        say(
            args,
            f"mean over {'every file' if name == 'all' else 'the validation files'}: fit "
            f"{format_percent(s['fit_nominal'])} -> {format_percent(s['fit'])}, RMS {format_percent(s['rms_nominal'])} "
            f"-> {format_percent(s['rms'])} ({nominal.output}, no-load {nominal.kind} then linear "
            f"{args.poles}p{args.zeros}z{label})",
        )
    if args.out:
        model.save(args.out)
        say(args, f"compensated model written to {args.out} (porosense predict --model {args.out} ...)")
    emit_json(
        {
            "model": str(args.model),
            "condition": args.condition,
            "order": [args.poles, args.zeros],
            "files": rows,
            "mean": summary,
            "out": str(args.out) if args.out else None,
        },
        args,
    )
    return 0
