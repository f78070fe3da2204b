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
        help="ident only: run these parts (oe, grid, scaling, cluster, 3dof, measured, builds, whsearch, "
        "wh2009; default all but builds and whsearch)",
    )
    p.add_argument(
        "--realisations",
        metavar="A-B",
        help="ident builds/whsearch only: the measured WH benchmark's realisations, N (the first N) or A-B "
        "(default 0-4)",
    )
    p.add_argument("--order", metavar="P,Z", help="ident builds only: WH poles,zeros (default 6,3)")
    p.add_argument(
        "--starts", type=int, metavar="K", help="ident builds/whsearch only: starts per nonlinear model (default 1/2)"
    )
    p.add_argument(
        "--evaluations", type=int, metavar="N", help="ident builds/whsearch only: evaluations per fit (default 200)"
    )
    p.add_argument(
        "--structures",
        nargs="+",
        metavar="S",
        help="ident whsearch only: structures of the search (default linear wiener hammerstein wh)",
    )
    p.add_argument(
        "--poles",
        type=int,
        nargs="+",
        metavar="P",
        help="ident whsearch only: pole counts of the search (default 1-10)",
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


def _wh_noise_options(realisations, order, starts, evaluations, structures, poles):
    """The Options of the measured WH benchmark's parts from the command line (None: defaults)."""
    from porosense.bench import wh_noise
    from porosense.ident import STRUCTURES

    if starts is not None and starts < 1:
        raise InputError("--starts must be at least 1")
    if evaluations is not None and evaluations < 1:
        raise InputError("--evaluations must be at least 1")
    if poles and min(poles) < 1:
        raise InputError("--poles must be at least 1")
    unknown = sorted(set(structures or ()) - set(STRUCTURES))
    if unknown:
        raise InputError(f"unknown structure(s) {', '.join(unknown)}; choose from {', '.join(STRUCTURES)}")
    defaults = wh_noise.Options()
    return wh_noise.Options(
        realisations=wh_noise.parse_realisations(realisations) if realisations else defaults.realisations,
        order=wh_noise.parse_order(order) if order else defaults.order,
        starts=starts,
        evaluations=evaluations or defaults.evaluations,
        structures=tuple(structures) if structures else defaults.structures,
        poles=tuple(poles) if poles else None,
    )


def run(args) -> int:
    try:
        module = importlib.import_module(f"porosense.bench.{args.area}")
    except ModuleNotFoundError as exc:
        raise InputError(f"benchmark area '{args.area}' is not available in this build") from exc
    wh_noise = (args.realisations, args.order, args.starts, args.evaluations, args.structures, args.poles)
    if args.area == "ident":
        result = module.run(args.size, only=args.only, wh2009=args.wh2009, wh_noise=_wh_noise_options(*wh_noise))
    elif args.only or args.wh2009 or any(v is not None for v in wh_noise):
        raise InputError(
            "--only, --wh2009, --realisations, --order, --starts, --evaluations, --structures and --poles belong to "
            "'porosense bench ident'"
        )
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
