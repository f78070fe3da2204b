"""``porosense ports``: list serial ports and mark likely Arduino Unos."""

from __future__ import annotations

import argparse

from porosense.cli._data import add_json_options, emit_json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "ports",
        help="list serial ports and mark likely Arduino Unos",
        description=(
            "List the serial ports of this computer with their USB vendor:product ids. Ports "
            "whose VID:PID belongs to an Arduino Uno (2341:0043, 2341:0001, 2A03:0043) or a "
            "common clone's USB-serial chip (1A86:7523 CH340, 0403:6001 FTDI) are marked and "
            "listed first. Pass the device path to other commands as --port."
        ),
        epilog="example: porosense ports --json",
    )
    add_json_options(p, "the ports (a list)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.device.ports import list_ports

    ports = list_ports()
    emit_json([p.to_dict() for p in ports], args)
    if args.json:
        return 0
    if not ports:
        print("no serial ports found (for the emulator use: porosense emulator --listen tcp://127.0.0.1:5000)")
        return 0
    for port in ports:
        print(port)
    return 0
