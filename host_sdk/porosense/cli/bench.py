"""``porosense bench AREA``: run one benchmark area and print its figures."""

from __future__ import annotations

import argparse
import importlib
import os

from porosense.bench import AREAS
from porosense.cli._data import add_json_options, emit_json
from porosense.errors import InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "bench",
        help="run a benchmark and print its figures",
        description=(
            "Run the benchmark of one area and print its figures. Areas: "
            + ", ".join(AREAS)
            + ". --size small is the quick CI-sized run; full (default outside CI) gives the "
            "figures the documentation quotes."
        ),
        epilog="example: porosense bench protocol --json",
    )
    p.add_argument("area", choices=AREAS, help="what to benchmark")
    add_json_options(p, "the figures")
    p.add_argument(
        "--size",
        choices=("small", "full"),
        default="small" if os.environ.get("CI") else "full",
        help="problem size (default: small under CI, full otherwise)",
    )
    p.add_argument(
        "--only",
        nargs="+",
        metavar="PART",
        help="ident only: run these parts (oe, grid, scaling, cluster, 3dof, measured, wh2009; default all)",
    )
    p.add_argument(
        "--wh2009",
        metavar="PATH",
        help="ident only: the 2009 Wiener-Hammerstein benchmark file (WienerHammerBenchmark.csv, "
        "nonlinearbenchmark.org): identify on the official estimation samples, print the test RMSE "
        "beside the published figures",
    )
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    try:
        module = importlib.import_module(f"porosense.bench.{args.area}")
    except ModuleNotFoundError as exc:
        raise InputError(f"benchmark area '{args.area}' is not available in this build") from exc
    if args.area == "ident":
        result = module.run(args.size, only=args.only, wh2009=args.wh2009)
    elif args.only or args.wh2009:
        raise InputError("--only and --wh2009 belong to 'porosense bench ident'")
    else:
        result = module.run(args.size)
    emit_json(result, args)
    if not args.json:
        for line in result.get("summary", []):
            print(line)
    if args.area == "firmware" and args.size == "full" and result.get("advertised_equals_measured") is False:
        from porosense.errors import DeviceError

        rates = result["max_clean_rates"]
        raise DeviceError(
            f"the firmware advertises {rates['advertised_max_hz']} Hz but sustains "
            f"{rates['measured_max_hz']} Hz with every channel, the IMU and the heaviest storable "
            "model: set SAMPLE_RATE_HZ max in protocol/messages.toml and run protocol/generate.py"
        )
    return 0
