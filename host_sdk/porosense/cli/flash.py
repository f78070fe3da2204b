"""``porosense flash``: write a model blob to the device and read back its MODEL_INFO."""

from __future__ import annotations

import argparse
from pathlib import Path

from porosense.errors import InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "flash",
        help="write a quantized model blob to the device's EEPROM",
        description=(
            "Send a model blob (porosense quantize) with MODEL_BEGIN, MODEL_CHUNK (112 bytes each) "
            "and MODEL_COMMIT, then read MODEL_INFO back and check length and CRC. The board writes it "
            "beside the running model, which keeps running until the new one is whole and checked: a "
            "reset or a disconnect during the write leaves the old model. A model identified at another "
            "sample rate than the board's is refused (exit 4) unless --set-rate sets the board's rate. "
            "When the new model does not fit beside the running one, --replace erases it first (the "
            "board then has no model until the write completes)."
        ),
        epilog="example: porosense flash --port socket://127.0.0.1:5000 model.bin",
    )
    p.add_argument("--port", required=True, metavar="URL", help="serial port or pyserial URL")
    p.add_argument("blob", metavar="MODEL.bin", help="model blob")
    p.add_argument("--set-rate", action="store_true",
                   help="set (and save) the board's SAMPLE_RATE_HZ to the model's rate when they differ")
    p.add_argument("--replace", action="store_true",
                   help="erase the running model first when the new one does not fit beside it")
    p.add_argument("--json", action="store_true", help="print the stored model's info as JSON")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.device import Device
    from porosense.quant import ModelBlob

    path = Path(args.blob)
    if not path.is_file():
        raise InputError(f"model blob {path} not found")
    data = path.read_bytes()
    blob = ModelBlob.from_bytes(data)  # refuse a bad file before touching the device
    with Device.open(args.port) as dev:
        rate = dev.check_model_rate(data, set_rate=args.set_rate)
        info = dev.write_model(data, replace=None if args.replace else False)
    if args.json:
        import json

        print(json.dumps({"port": args.port, "bytes": len(data), "rate_hz": rate, **info.to_dict()}, default=float))
        return 0
    print(f"flashed {len(data)} bytes to {args.port}: model 0x{info.model_id:08X}, CRC 0x{info.crc:04X}, "
          f"{blob.n_inputs} inputs, {blob.n_outputs} outputs, {rate} Hz, out_scale "
          + ", ".join(f"{s:.6g}" for s in info.out_scale[: blob.n_outputs]))
    return 0
