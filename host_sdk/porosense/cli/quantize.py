"""``porosense quantize``: identified model -> fixed-point blob for the firmware."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "quantize",
        help="turn an identified model into the firmware's fixed-point model blob",
        description=(
            "Quantize an identified model (porosense identify --save) for the on-device estimator: "
            "second-order sections, Q formats and scaling chosen automatically, written as the "
            "model blob (at most 952 bytes: the 1 KB EEPROM's model region). Inputs are dR in %, "
            "sent by the device in 0.01 % steps; estimates come back as int16 times out_scale "
            "(output unit per LSB). --data recordings set the input range and give the fit of the "
            "fixed-point reference against the float model and the data in the report."
        ),
        epilog="example: porosense quantize model.json --out model.bin --report quant.json --data step_20.csv",
    )
    p.add_argument("model", metavar="MODEL.json", help="identified model file")
    p.add_argument("--out", metavar="MODEL.bin", help="where to write the blob (default: MODEL.bin beside the model)")
    p.add_argument("--report", metavar="R.json", help="write the quantization report as JSON")
    p.add_argument("--header", metavar="MODEL.h", help="also write a C header with the coefficients")
    p.add_argument("--data", nargs="*", default=[], metavar="FILE",
                   help="recordings (CSV or .mat with the model's columns) for the range and the fit report")
    p.add_argument("--input-range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="input range in %% dR that must never overflow (default: data range + 25 %%, "
                        "or -100..100 without data)")
    p.add_argument("--model-id", type=lambda v: int(v, 0), help="32-bit tag stored in the blob")
    p.add_argument("--json", action="store_true", help="print the quantization report as JSON")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import math

    from porosense.cli._data import load_model_checked, output_file, read_tables, require_columns
    from porosense.errors import InputError
    from porosense.quant import c_header, quantize

    args.out = args.out or str(Path(args.model).with_suffix(".bin"))
    for opt in ("out", "report", "header"):
        if getattr(args, opt):
            output_file(getattr(args, opt), f"--{opt}")
    if args.input_range is not None:
        lo, hi = args.input_range
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InputError(f"--input-range {lo:g} {hi:g}: give two finite numbers LO < HI (% dR)")
    if args.model_id is not None and not 0 <= args.model_id <= 0xFFFFFFFF:
        raise InputError(f"--model-id {args.model_id:#x} does not fit in 32 bits (0..0xFFFFFFFF)")
    model = load_model_checked(args.model)
    structure = model.to_structure()
    tables = read_tables(args.data, args)
    for table in tables:
        require_columns(table, list(model.inputs))
        table.require_finite(list(model.inputs))
    result = quantize(structure, recordings=tables, input_range=args.input_range, model_id=args.model_id)
    Path(args.out).write_bytes(result.to_bytes())
    if args.report:
        result.report.to_json(args.report)
    if args.header:
        Path(args.header).write_text(c_header(result.blob, Path(args.header).stem))
    if args.json:
        import json

        print(json.dumps({"out": str(args.out), "bytes": result.blob.length, "crc": result.blob.crc,
                          "model_id": result.blob.model_id, "report": result.report.to_dict()}, indent=2,
                         default=float))
        return 0
    for line in result.report.lines():
        print(line)
    print(f"blob written to {args.out} ({result.blob.length} bytes, CRC 0x{result.blob.crc:04X}, "
          f"id 0x{result.blob.model_id:08X})")
    return 0
