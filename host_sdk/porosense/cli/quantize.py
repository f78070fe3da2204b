"""``porosense quantize``: identified model -> fixed-point blob for the firmware."""

from __future__ import annotations

import argparse
from pathlib import Path

from porosense.cli._args import add_deprecated, add_legacy_positional, take_positional
from porosense.cli._data import add_column_options, add_data_options, add_json_options
from porosense.files import write_bytes, write_text


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "quantize",
        help="turn an identified model into the firmware's fixed-point model blob",
        description=(
            "Quantize an identified model (porosense identify --save) for the on-device estimator: "
            "second-order sections, Q formats and scaling chosen automatically, written as the "
            "model blob (at most 776 bytes: the 1 KB EEPROM's model area). The device sends dR in "
            "0.01 % steps; the model file says whether its inputs are dR in % or dR/100 (--input-unit "
            "for files that do not), and the blob stores that scaling and the model's sample period. "
            "Estimates come back as int16 times out_scale "
            "(output unit per LSB). --data recordings set the input range and give the fit of the "
            "fixed-point reference against the float model and the data in the report."
        ),
        epilog="example: porosense quantize --model model.json --out model.bin --json-out quant.json --data step_20.csv",
    )
    p.add_argument("--model", metavar="MODEL.json", help="identified model file (porosense identify --out)")
    add_legacy_positional(p, "model")
    p.add_argument("--out", metavar="MODEL.bin", help="where to write the blob (default: MODEL.bin beside the model)")
    add_deprecated(p, "--report", "--json-out", "report")
    p.add_argument("--header", metavar="MODEL.h", help="also write a C header with the coefficients")
    p.add_argument(
        "--data",
        nargs="+",
        default=[],
        metavar="FILE",
        help="recordings (CSV or .mat with the model's columns) for the range and the fit report",
    )
    add_column_options(p, outputs=False)
    p.add_argument(
        "--input-range",
        nargs=2,
        type=float,
        metavar=("LO", "HI"),
        help="input range in %% dR that must never overflow (default: data range + 25 %%, or -100..100 without data)",
    )
    p.add_argument(
        "--input-unit",
        choices=["%", "dR/100"],
        help="unit of the model's inputs when its file does not say (dR in %% or dR/100)",
    )
    p.add_argument("--model-id", type=lambda v: int(v, 0), help="32-bit tag stored in the blob")
    p.add_argument(
        "--store",
        choices=("eeprom", "flash"),
        default="eeprom",
        help="model store the blob is for: eeprom (776 B, shared by two models) or flash "
        "(1,016 B per slot; flash --store flash)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="write the blob although the model is refused (breakpoints not increasing, a fixed-point estimate "
        "that saturates or fits the float model below 95 %%, a fit below the data's mean), with a warning; "
        "replace an existing --out (an unstable model is refused even so: the board refuses it)",
    )
    add_json_options(p, "the blob's facts and the quantization report")
    add_data_options(p, ts_help="sample period of the data in s (default: the data's; checked against the model's)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import dataclasses
    import math

    from porosense.cli._data import (
        bind_columns,
        emit_json,
        load_model_checked,
        model_period,
        normalise_json_args,
        output_file,
        read_tables,
        require_columns,
    )
    from porosense.errors import InputError, ModelError
    from porosense.quant import c_header, quantize

    take_positional(args, "model", "--model")
    normalise_json_args(args)
    args.out = args.out or str(Path(args.model).with_suffix(".bin"))
    args.report = getattr(args, "report", None)  # the old spelling of --json-out (quantization report only)
    output_file(args.out, "--out", force=bool(getattr(args, "force", False)))
    for opt in ("report", "header"):
        if getattr(args, opt):
            output_file(getattr(args, opt), f"--{opt}")
    if args.input_range is not None:
        lo, hi = args.input_range
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InputError(f"--input-range {lo:g} {hi:g}: give two finite numbers LO < HI (% dR)")
    if args.model_id is not None and not 0 <= args.model_id <= 0xFFFFFFFF:
        raise InputError(f"--model-id {args.model_id:#x} does not fit in 32 bits (0..0xFFFFFFFF)")
    structure = load_model_checked(args.model).to_structure()
    if args.input_unit:
        declared = {u for u in structure.input_units if u is not None}
        if declared and declared != {args.input_unit}:
            raise ModelError(
                f"{args.model} declares its inputs in {', '.join(sorted(declared))}, not {args.input_unit}"
            )
        structure = dataclasses.replace(structure, input_units=(args.input_unit,) * len(structure.inputs))
    tables = read_tables(args.data, args)
    if tables:
        model_period(tables, structure, args)
        bind_columns(tables, args, structure.inputs, model=structure)
    for table in tables:
        require_columns(table, list(structure.inputs))
        table.require_finite(list(structure.inputs))
    # --input-range is in % of dR; the structure may work in dR/100.
    per_percent = structure.input_lsb() / 0.01
    input_range = None if args.input_range is None else [v * per_percent for v in args.input_range]
    recs = [_scaled(t, structure, per_percent) for t in tables]
    from porosense.protocol.model_layout import FLASH_BLOB_MAX, MAX_BLOB_LEN

    result = quantize(
        structure,
        recordings=recs,
        input_range=input_range,
        model_id=args.model_id,
        capacity=FLASH_BLOB_MAX if args.store == "flash" else MAX_BLOB_LEN,
        force=args.force,
    )
    import sys

    for note in result.report.notes:
        if note.startswith("forced past a refusal"):
            print(f"porosense quantize: warning: {note}", file=sys.stderr)
    write_bytes(args.out, result.to_bytes())
    if args.report:
        result.report.to_json(args.report)
    if args.header:
        write_text(args.header, c_header(result.blob, Path(args.header).stem))
    doc = {
        "out": str(args.out),
        "bytes": result.blob.length,
        "crc": result.blob.crc,
        "ts_us": result.blob.ts_us,
        "input_lsb_percent": result.blob.input_lsb,
        "model_id": result.blob.model_id,
        "report": result.report.to_dict(),
    }
    emit_json(doc, args)
    if args.json:
        return 0
    for line in result.report.lines():
        print(line)
    print(
        f"blob written to {args.out} ({result.blob.length} bytes, CRC 0x{result.blob.crc:04X}, "
        f"id 0x{result.blob.model_id:08X}, {result.blob.rate_hz:g} Hz)"
    )
    return 0


def _scaled(table, structure, per_percent: float):
    """A recording's columns with the model's inputs converted from dR in % to the model's unit."""
    from types import SimpleNamespace

    import numpy as np

    cols = dict(table.columns)
    for name in structure.inputs:
        if name in cols:
            cols[name] = np.asarray(cols[name], dtype=float) * per_percent
    return SimpleNamespace(columns=cols, meta=getattr(table, "meta", {}) or {}, path=getattr(table, "path", None))
