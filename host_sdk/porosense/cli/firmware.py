"""``porosense firmware``: the firmware this package carries (upload with avrdude, paths)."""

from __future__ import annotations

import argparse

from porosense.cli._data import add_json_options, emit_json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "firmware",
        help="flash the packaged Uno firmware or show where its files are",
        description=(
            "The Uno firmware built with this package (HEX and ELF). 'upload' flashes it "
            "with avrdude through the Uno's bootloader (115200 baud, ATmega328P); 'where' "
            "prints the packaged files (firmware, core sources, simboard harness)."
        ),
        epilog="example: porosense firmware upload --port /dev/ttyACM0",
    )
    p.add_argument("action", choices=("upload", "where"), help="what to do")
    p.add_argument("--port", default=None, help="upload: serial port of the Uno (e.g. /dev/ttyACM0)")
    p.add_argument("--hex", default=None, help="upload: another Intel HEX file (default: the packaged one)")
    p.add_argument("--avrdude", default=None, help="upload: path of avrdude (default: found on PATH)")
    add_json_options(p, "the result")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.errors import InputError
    from porosense.firmware import files

    if args.action == "upload":
        from porosense.firmware.upload import upload

        if not args.port:
            raise InputError("upload needs --port (e.g. --port /dev/ttyACM0; `porosense ports` lists them)")
        result = upload(args.port, args.hex, args.avrdude)
        emit_json(result.to_dict(), args)
        if not args.json:
            print(result)
        return 0
    paths = {
        "hex": files.hex_path(),
        "elf": files.elf_path(),
        "core": files.core_dir(),
        "simboard": files.harness_path(),
    }
    info = {k: {"path": str(v), "present": v.exists()} for k, v in paths.items()}
    emit_json(info, args)
    if not args.json:
        for k, v in info.items():
            print(f"{k:9s} {v['path']}{'' if v['present'] else '  (absent)'}")
    return 0
