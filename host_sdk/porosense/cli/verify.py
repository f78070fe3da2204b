"""``porosense verify``: replay a recording through the device and compare with the reference."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

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
            "a recording with a time column t must be sampled at that rate too (exit 4 otherwise). "
            "Exits 0 only when every sample of every output is identical."
        ),
        epilog="example: porosense verify --port socket://127.0.0.1:5000 model.bin --data step_20.csv",
    )
    p.add_argument("--port", required=True, metavar="URL", help="serial port or pyserial URL")
    p.add_argument("blob", metavar="MODEL.bin", help="model blob flashed on the device")
    p.add_argument("--data", required=True, metavar="FILE", help="CSV recording with dR_0..dR_2 columns (%%)")
    p.add_argument("--inputs", nargs="*", metavar="COL", help="input columns (default dR_0 .. dR_{n-1})")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import numpy as np

    from porosense.data import read_table
    from porosense.device import Device
    from porosense.protocol.model_layout import FLASH_BLOB_MAX
    from porosense.quant import FixedPointEstimator, ModelBlob

    path = Path(args.blob)
    if not path.is_file():
        raise InputError(f"model blob {path} not found")
    data = path.read_bytes()
    blob = ModelBlob.from_bytes(data, max_length=FLASH_BLOB_MAX)  # a model of either store
    table = read_table(args.data)
    cols = args.inputs or [f"dR_{i}" for i in range(blob.n_inputs)]
    missing = [c for c in cols if c not in table.columns]
    if missing:
        raise InputError(f"{args.data}: no column(s) {', '.join(missing)}")
    if len(table) == 0:
        raise InputError(f"{args.data}: no samples to replay (only a header?)")
    dr = np.zeros((len(table.columns[cols[0]]), 3))
    for i, c in enumerate(cols):
        dr[:, i] = table.columns[c]
    if not np.all(np.isfinite(dr)):
        raise InputError(f"{args.data}: empty or non-finite cells in {', '.join(cols)}")
    _check_data_rate(table, blob, args.data)
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
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        verdict = "identical" if mismatches == 0 else f"{mismatches} values differ (first at sample {first})"
        print(f"replayed {len(counts)} samples x {n_out} outputs through {args.port} (model in {store}): {verdict}")
    return 0 if mismatches == 0 else 1


def _check_data_rate(table, blob, name) -> None:
    """A recording with a time column must be sampled at the model's rate (1 % tolerance)."""
    import numpy as np

    from porosense.errors import ModelError

    t = table.columns.get("t")
    if t is None or len(t) < 2:
        return
    ts = float(np.median(np.diff(np.asarray(t, dtype=float))))
    if not abs(ts - blob.ts) <= 0.01 * blob.ts:
        raise ModelError(
            f"{name} is sampled every {ts * 1000:.4g} ms but the model at {blob.ts * 1000:.4g} ms "
            f"({blob.rate_hz:g} Hz): replaying it would not test what the board computes"
        )


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
