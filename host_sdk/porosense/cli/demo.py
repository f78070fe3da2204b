"""``porosense demo``: the whole pipeline on a board, with a report."""

from __future__ import annotations

import argparse

from porosense.cli._args import ACTUATORS, add_deprecated, add_params_option, load_params
from porosense.cli._data import add_json_options, emit_json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "demo",
        help="identify, quantize, flash and verify an actuator's strain estimator end to end",
        description=(
            "Run the paper's identification protocol on a board (vacuum steps at -10, -20, -40 and -60 kPa "
            "in duplicate and the staircase; the 3-DoF patterns for the segment), identify linear, Hammerstein, "
            "Wiener and Wiener-Hammerstein models with an order search (the 3-DoF segment at the paper's orders: WH, "
            "2 poles, 10 breakpoints, stored in the flash model store when the EEPROM cannot hold it), print the paper-style table (fit % and "
            "RMS % per structure and recording), quantize the best model, flash it, verify it by replay, then "
            "stream a validation experiment and report the on-device estimate's fit live. Writes figures and a "
            "summary page (Markdown and self-contained HTML) to OUT/ACTUATOR/."
        ),
        epilog=(
            "examples:\n"
            "  porosense demo                                  # contractor on the emulator\n"
            "  porosense demo --actuator all --out out/demo\n"
            "  porosense demo --actuator 3dof --board simboard # the real firmware in simavr"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--actuator",
        default="contractor",
        choices=(*ACTUATORS, "all"),
        help="which actuator (default: contractor)",
    )
    p.add_argument(
        "--board",
        default="emulator",
        metavar="emulator|simboard|URL",
        help="the emulator (default; the firmware core on this computer), the firmware in simavr, or a serial URL of a real board "
        "(a real board gives no ground truth: the demo records and stops)",
    )
    p.add_argument("--out", default="out/demo", help="report folder (default: out/demo)")
    p.add_argument(
        "--rate",
        type=int,
        default=50,
        help=f"sample rate in Hz, {_rate_limits()[0]}..{_rate_limits()[1]} (the board's SAMPLE_RATE_HZ "
        "limits; default 50)",
    )
    p.add_argument(
        "--max-poles",
        type=int,
        default=3,
        help="largest number of poles in the order search, 1..10 (default 3; the paper's grid is 10)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated actuator (default 0)")
    add_params_option(p)
    add_json_options(p, "the results")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_deprecated(p, "--no-progress", "--quiet", "quiet", nargs=0)
    p.set_defaults(func=run)
    return p


def _rate_limits() -> tuple[int, int]:
    """SAMPLE_RATE_HZ limits of the protocol catalogue: what the firmware accepts (Hz)."""
    from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

    spec = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ]
    return int(spec.min), int(spec.max)


def run(args) -> int:
    from porosense.errors import InputError
    from porosense.workflows.demo import run_demo

    lo, hi = _rate_limits()
    if not lo <= args.rate <= hi:
        raise InputError(f"--rate {args.rate} Hz outside {lo}..{hi} (the board's SAMPLE_RATE_HZ limits)")
    if not 1 <= args.max_poles <= 10:
        raise InputError(f"--max-poles {args.max_poles} outside 1..10")
    actuators = ACTUATORS if args.actuator == "all" else (args.actuator,)
    log = (lambda *a, **k: None) if args.json else print
    physics = load_params(args)
    results = [
        run_demo(
            a,
            args.board,
            out_dir=args.out,
            rate_hz=args.rate,
            max_poles=args.max_poles,
            seed=args.seed,
            progress=not args.quiet,
            log=log,
            physics=physics,
        )
        for a in actuators
    ]
    emit_json([r.to_dict() for r in results], args)
    return 0
