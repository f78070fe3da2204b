"""``porosense predict``: simulate a saved model on a CSV file."""

from __future__ import annotations

import argparse

from porosense.errors import InputError

TIME_COLUMNS = ("t", "time", "t_s")


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "predict",
        help="simulate a saved model on a CSV file from rest",
        description=(
            "Simulate an identified model (porosense identify --save) on the whole CSV file from "
            "rest and write one column per output named <output>_pred in the output's unit, plus "
            "the time column (t, s) when the file has one."
        ),
        epilog="example: porosense predict --model model.json --data step_20.csv --out pred.csv",
    )
    p.add_argument("--model", required=True, metavar="MODEL.json", help="model file")
    p.add_argument("--data", required=True, metavar="FILE", help="CSV file with the model's input columns")
    p.add_argument("--out", required=True, metavar="PRED.csv", help="where to write the predictions")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import numpy as np

    from porosense.data import read_table
    from porosense.ident import load_model

    model = load_model(args.model)
    table = read_table(args.data)
    missing = [c for c in model.inputs if c not in table.columns]
    if missing:
        raise InputError(f"{args.data}: no column(s) {', '.join(missing)} needed by the model")
    u = np.column_stack([table.columns[c] for c in model.inputs])
    if not np.all(np.isfinite(u)):
        raise InputError(f"{args.data}: empty or non-finite cells in the input columns")
    yhat = model.predict(u=u)
    yhat = yhat[:, None] if yhat.ndim == 1 else yhat
    outputs = [model.output] if hasattr(model, "output") else list(model.outputs)
    names, cols = [], []
    tcol = next((c for c in TIME_COLUMNS if c in table.columns), None)
    if tcol is not None:
        names.append(tcol)
        cols.append(table.columns[tcol])
    names += [f"{o}_pred" for o in outputs]
    cols += [yhat[:, j] for j in range(yhat.shape[1])]
    data = np.column_stack(cols)
    with open(args.out, "w") as fh:
        fh.write(",".join(names) + "\n")
        for row in data:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
    if getattr(args, "json", False):
        import json

        print(json.dumps({"out": str(args.out), "samples": int(len(data)), "columns": names}))
    else:
        print(f"{len(data)} samples of {', '.join(names[-yhat.shape[1]:])} written to {args.out}")
    return 0
