"""``porosense flash``: write a model blob to the device and read back its MODEL_INFO."""

from __future__ import annotations

import argparse
from pathlib import Path

from porosense.cli._args import add_legacy_positional, take_positional
from porosense.cli._data import add_json_options, blob_checked, emit_json, normalise_json_args
from porosense.errors import InputError
from porosense.files import write_text


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "flash",
        help="write a quantized model blob to the device's EEPROM or flash model store",
        description=(
            "Send a model blob (porosense quantize) with MODEL_BEGIN, MODEL_CHUNK (112 bytes each) "
            "and MODEL_COMMIT, then read MODEL_INFO back and check length and CRC. The board writes it "
            "beside the running model, which keeps running until the new one is whole and checked: a "
            "reset or a disconnect during the write leaves the old model. A model identified at another "
            "sample rate than the board's is refused (exit 4) unless --set-rate sets the board's rate. "
            "When the new model does not fit beside the running one, --replace erases it first (the "
            "board then has no model until the write completes). "
            "--store flash puts the model into the flash model store instead (two 1,024-byte slots at the "
            "top of the application flash, room for the paper's 3-DoF WH set twice): an Intel HEX holding "
            "only the slot that is not running, with the commit counter after the running model's, uploaded "
            "with avrdude -D through the Uno's bootloader; the board resets and runs it. A torn upload "
            "leaves the previous model running. --hex-out writes the HEX without uploading. Boards on a "
            "socket:// port have no bootloader: write the HEX with --hex-out (the Python API uploads into "
            "the simboard and the emulator: SimBoard.program_flash, Emulator.program_flash)."
        ),
        epilog="example: porosense flash --port socket://127.0.0.1:5000 --model model.bin",
    )
    p.add_argument("--port", required=True, metavar="URL", help="serial port or pyserial URL")
    p.add_argument("--model", metavar="MODEL.bin", help="model blob (porosense quantize --out)")
    add_legacy_positional(p, "model")
    p.add_argument(
        "--set-rate",
        action="store_true",
        help="set (and save) the board's SAMPLE_RATE_HZ to the model's rate when they differ",
    )
    p.add_argument(
        "--replace", action="store_true", help="erase the running model first when the new one does not fit beside it"
    )
    p.add_argument(
        "--store",
        choices=("eeprom", "flash"),
        default="eeprom",
        help="eeprom (default): over the protocol; flash: the flash model store, by upload",
    )
    p.add_argument("--hex-out", metavar="FILE.hex", help="--store flash: write the slot's Intel HEX here, no upload")
    p.add_argument("--avrdude", default=None, help="--store flash: path of avrdude (default: found on PATH)")
    add_json_options(p, "the stored model's info")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.device import Device

    take_positional(args, "model", "--model")
    normalise_json_args(args)
    path = Path(args.model)
    if not path.is_file():
        raise InputError(f"model blob {path} not found")
    data = path.read_bytes()
    if args.store == "flash":
        return _run_flash_store(args, data)
    if args.hex_out:
        raise InputError("--hex-out needs --store flash")
    blob = blob_checked(path, data)  # refuse a bad file before touching the device
    with Device.open(args.port) as dev:
        rate = dev.check_model_rate(data, set_rate=args.set_rate)
        info = dev.write_model(data, replace=None if args.replace else False)
    emit_json({"port": args.port, "bytes": len(data), "rate_hz": rate, **info.to_dict()}, args)
    if args.json:
        return 0
    print(
        f"flashed {len(data)} bytes to {args.port}: model 0x{info.model_id:08X}, CRC 0x{info.crc:04X}, "
        f"{blob.n_inputs} inputs, {blob.n_outputs} outputs, {rate} Hz, out_scale "
        + ", ".join(f"{s:.6g}" for s in info.out_scale[: blob.n_outputs])
    )
    return 0


def _run_flash_store(args, data: bytes) -> int:
    """--store flash: plan the slot from the running model, write the HEX, upload it."""
    import tempfile

    from porosense.device import Device
    from porosense.errors import DeviceError
    from porosense.firmware import upload as avr_upload
    from porosense.firmware.flash_store import plan_upload, require_flash_store
    from porosense.protocol.model_layout import FLASH_BLOB_MAX

    blob = blob_checked(args.model, data, max_length=FLASH_BLOB_MAX)  # refuse a bad file first
    with Device.open(args.port) as dev:
        require_flash_store(dev.info)
        rate = dev.check_model_rate(data, set_rate=args.set_rate)
        plan = plan_upload(data, dev.model_info())
    hex_text = plan.to_hex()
    if args.hex_out:
        out = Path(args.hex_out)
        if not out.parent.is_dir():
            raise InputError(f"folder {out.parent} does not exist")
        write_text(out, hex_text)
        result = {"port": args.port, "bytes": len(data), "hex": str(out), **plan.to_dict()}
        emit_json(result, args)
        if not args.json:
            print(
                f"wrote {out}: {len(data)}-byte model into flash slot {plan.slot} (counter {plan.seq}, "
                f"{plan.to_dict()['pages']} pages at 0x{plan.address:04X}); upload with avrdude -D"
            )
        return 0
    if args.port.startswith(("socket://", "loop://", "rfc2217://")):
        raise InputError(
            f"{args.port} has no bootloader to upload to: write the HEX with --hex-out "
            "(the simboard and the emulator take uploads through their Python API)"
        )
    with tempfile.TemporaryDirectory(prefix="porosense-flash-") as tmp:
        hex_file = Path(tmp) / "model_slot.hex"
        hex_file.write_text(hex_text)
        avr_upload.upload(args.port, hex_file, avrdude=args.avrdude, image=False)
    with Device.open(args.port) as dev:
        info = dev.model_info()
    if not info.valid or info.crc != blob.crc or info.slot != 2 + plan.slot:
        raise DeviceError(f"uploaded flash slot {plan.slot} but the board runs: {info}")
    emit_json({"port": args.port, "bytes": len(data), "rate_hz": rate, **plan.to_dict(), **info.to_dict()}, args)
    if args.json:
        return 0
    print(
        f"flashed {len(data)} bytes to flash slot {plan.slot} of {args.port} (counter {plan.seq}): "
        f"model 0x{info.model_id:08X}, CRC 0x{info.crc:04X}, {rate} Hz"
    )
    return 0
