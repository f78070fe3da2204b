"""``porosense verify``: replay a recording through the device and compare with the reference."""

from __future__ import annotations

import argparse
from pathlib import Path

from porosense.cli._args import add_deprecated, add_legacy_positional, columns, take_positional
from porosense.cli._data import (
    add_data_options,
    add_json_options,
    blob_checked,
    emit_json,
    model_period,
    normalise_json_args,
    read_tables,
    require_columns,
)
from porosense.errors import DeviceError, InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "verify",
        help="replay a recording through the device's estimator and compare bit for bit",
        description=(
            "Replay the dR columns (%, sent as 0.01 % steps) of a recording through the device's "
            "estimator (REPLAY, 16 samples per frame) and compare its int16 estimates with the "
            "Python bit-exact reference of the same blob. The device must hold this blob (porosense "
            "flash), with the same sample period and input scaling, and sample at the model's rate; "
            "a recording with a time column must be sampled at that rate too (exit 2 otherwise). "
            "Exits 0 only when every sample of every output is identical."
        ),
        epilog="example: porosense verify --port socket://127.0.0.1:5000 --model model.bin --data step_20.csv "
        "--output strain_0",
    )
    p.add_argument("--port", required=True, metavar="URL", help="serial port or pyserial URL")
    p.add_argument("--model", metavar="MODEL.bin", help="model blob flashed on the device (porosense quantize --out)")
    add_legacy_positional(p, "model")
    p.add_argument(
        "--data", required=True, nargs="+", metavar="FILE", help="one recording (CSV or .mat) with the dR columns (%%)"
    )
    p.add_argument("--input", nargs="+", metavar="COL", help="input columns, dR in %% (default dR_0 .. dR_{n-1})")
    add_deprecated(p, "--inputs", "--input", "input", nargs="*")
    p.add_argument(
        "--output",
        nargs="+",
        metavar="COL",
        help="measured output columns: the fit of the board's estimates to them is printed (default: none)",
    )
    add_json_options(p, "the result")
    add_data_options(p, ts_help="sample period of the data in s (default: the data's; checked against the model's)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import numpy as np

    from porosense.device import Device
    from porosense.protocol.model_layout import FLASH_BLOB_MAX
    from porosense.quant import FixedPointEstimator

    take_positional(args, "model", "--model")
    normalise_json_args(args)
    if len(args.data) != 1:
        raise InputError(f"--data names {len(args.data)} files; verify replays one")
    args.data = args.data[0]
    path = Path(args.model)
    if not path.is_file():
        raise InputError(f"model blob {path} not found")
    data = path.read_bytes()
    blob = blob_checked(path, data, max_length=FLASH_BLOB_MAX)  # a model of either store
    (table,) = read_tables([args.data], args)
    cols = columns(args.input, "input", args) if args.input else [f"dR_{i}" for i in range(blob.n_inputs)]
    if len(cols) != blob.n_inputs:
        raise InputError(f"--input names {len(cols)} columns; the blob takes {blob.n_inputs} inputs")
    outs = columns(args.output, "output", args) if args.output else []
    if len(outs) > blob.n_outputs:
        raise InputError(f"--output names {len(outs)} columns; the blob has {blob.n_outputs} outputs")
    require_columns(table, outs)
    table.require_finite(outs)
    require_columns(table, cols)
    dr = np.zeros((len(table.columns[cols[0]]), 3))
    for i, c in enumerate(cols):
        dr[:, i] = table.columns[c]
    if not np.all(np.isfinite(dr)):
        raise InputError(f"{args.data}: empty or non-finite cells in {', '.join(cols)}")
    model_period([table], blob, args, what=f"the model {args.model}")
    counts = np.clip(np.round(dr * 100.0), -32768, 32767).astype(np.int64)
    ref, _ = FixedPointEstimator(blob).run(counts)
    with Device.open(args.port) as dev:
        info = dev.model_info()
        if not info.valid or info.crc != blob.crc:
            raise DeviceError(
                f"the device holds model CRC 0x{info.crc:04X} ({info.status}), not this blob's "
                f"0x{blob.crc:04X}: run porosense flash first"
            )
        _check_stored_header(dev, blob)
        dev.check_model_rate(data)
        got = dev.replay(counts)
    store = f"{info.store} slot {info.slot % 2}"
    n_out = blob.n_outputs
    diff = np.asarray(got[:, :n_out], dtype=np.int64) != ref[:, :n_out].astype(np.int64)
    mismatches = int(np.count_nonzero(diff))
    first = int(np.argmax(np.any(diff, axis=1))) if mismatches else None
    result = {
        "samples": len(counts),
        "outputs": n_out,
        "mismatched_values": mismatches,
        "first_mismatch_sample": first,
        "identical": mismatches == 0,
        "store": info.store,
        "slot": info.slot,
        "seq": info.seq,
    }
    if outs:
        # The board's estimates in output units, scored by the one fit every command prints (from rest:
        # the replay resets the estimator first).
        from porosense.ident.scoring import score_simulation

        estimates = np.asarray(got[:, : len(outs)], dtype=float) * np.asarray(blob.out_scale[: len(outs)], float)
        measured = np.column_stack([table.columns[o] for o in outs])
        scored = score_simulation(estimates, measured, outs)
        result["fit"], result["rms"] = scored.fit, scored.rms
    emit_json(result, args)
    if not args.json:
        verdict = "identical" if mismatches == 0 else f"{mismatches} values differ (first at sample {first})"
        print(f"replayed {len(counts)} samples x {n_out} outputs through {args.port} (model in {store}): {verdict}")
        for o in outs:
            print(f"board's estimate of {scored.line(o)} (simulated from rest)")
    return 0 if mismatches == 0 else 1


def _check_stored_header(dev, blob) -> None:
    """The device's stored blob has this blob's sample period and input scaling."""
    import struct

    from porosense.errors import ModelError
    from porosense.protocol.model_layout import HEADER_LEN, HEADER_OFFSETS

    head = dev.read_model_bytes(0, HEADER_LEN)
    ts_us = struct.unpack_from("<I", head, HEADER_OFFSETS["ts_us"])[0]
    lsb = struct.unpack_from("<f", head, HEADER_OFFSETS["input_lsb"])[0]
    if ts_us != blob.ts_us or lsb != blob.input_lsb:
        raise ModelError(
            f"the device's model has Ts {ts_us} us and input scaling {lsb:g} %/LSB, this blob "
            f"{blob.ts_us} us and {blob.input_lsb:g} %/LSB"
        )
