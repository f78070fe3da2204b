"""``porosense firmware``: the firmware this package carries (upload with avrdude, paths)."""

from __future__ import annotations

import argparse
import json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "firmware",
        help="flash the packaged Uno firmware or show where its files are",
        description=("The Uno firmware built with this package (HEX and ELF). 'upload' flashes it "
                     "with avrdude through the Uno's bootloader; 'where' prints the packaged files."),
        epilog="example: porosense firmware upload --port /dev/ttyACM0",
    )
    fsub = p.add_subparsers(dest="action", metavar="ACTION")
    up = fsub.add_parser("upload", help="flash the firmware with avrdude")
    up.add_argument("--port", required=True, help="serial port of the Uno (e.g. /dev/ttyACM0)")
    up.add_argument("--hex", default=None, help="another Intel HEX file (default: the packaged one)")
    up.add_argument("--avrdude", default=None, help="path of avrdude (default: found on PATH)")
    up.add_argument("--json", action="store_true", help="print the result as JSON")
    where = fsub.add_parser("where", help="print the packaged firmware files")
    where.add_argument("--json", action="store_true", help="print the paths as JSON")
    p.set_defaults(func=run, _parser=p)
    return p


def run(args) -> int:
    from porosense.firmware import files

    if args.action == "upload":
        from porosense.firmware.upload import upload

        result = upload(args.port, args.hex, args.avrdude)
        print(json.dumps(result.to_dict()) if args.json else result)
        return 0
    if args.action == "where":
        paths = {"hex": files.hex_path(), "elf": files.elf_path(), "core": files.core_dir(),
                 "simboard": files.harness_path()}
        info = {k: {"path": str(v), "present": v.exists()} for k, v in paths.items()}
        if args.json:
            print(json.dumps(info))
        else:
            for k, v in info.items():
                print(f"{k:9s} {v['path']}{'' if v['present'] else '  (absent)'}")
        return 0
    args._parser.print_help()
    return 1
