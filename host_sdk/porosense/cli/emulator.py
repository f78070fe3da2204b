"""``porosense emulator``: serve the board without hardware (the firmware's core) in the foreground."""

from __future__ import annotations

import argparse
import sys
import time

from porosense.cli._args import ACTUATORS, add_params_option, load_params
from porosense.cli._data import add_json_options, emit_json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "emulator",
        help="serve an emulated board (protocol over TCP or a pty)",
        description=(
            "Run the porosense board without hardware: the firmware's own core (commands, NAKs, "
            "model store, estimator, host-link watchdog, SAMPLE telemetry), compiled for this "
            "computer, over a simulated actuator. Clients connect with the printed pyserial "
            "URL. By default the board's clock follows the samples the host reads (as fast as "
            "possible); --realtime paces it by the wall clock and sends at 115200 baud from a "
            "64-byte transmit buffer, dropping telemetry that does not fit, like the board. "
            "Fault rates are probabilities per byte (0..1)."
        ),
        epilog=(
            "example: porosense emulator --listen tcp://127.0.0.1:5000 --actuator 3dof --realtime\n"
            '         then: python -c "from porosense.device import Device; '
            "print(Device.open('socket://127.0.0.1:5000').hello())\""
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--listen",
        default="tcp://127.0.0.1:5000",
        help="tcp://HOST:PORT (PORT 0 picks a free one) or pty (default: %(default)s)",
    )
    p.add_argument(
        "--actuator",
        default="contractor",
        choices=ACTUATORS,
        help="simulated actuator (default: %(default)s)",
    )
    p.add_argument("--porosity", type=float, default=None, help="porosity in %% (default: the actuator's)")
    p.add_argument("--load-g", type=float, default=0.0, help="hanging load in g (default: 0)")
    p.add_argument("--seed", type=int, default=0, help="noise seed of the plant and the faults")
    add_params_option(p)
    p.add_argument("--realtime", action="store_true", help="pace the board and its UART by the wall clock")
    p.add_argument("--speed", type=float, default=1.0, help="with --realtime: time factor (default 1)")
    p.add_argument(
        "--corrupt", type=float, default=0.0, metavar="RATE", help="corrupt this fraction of bytes in both directions"
    )
    p.add_argument(
        "--drop", type=float, default=0.0, metavar="RATE", help="drop this fraction of bytes in both directions"
    )
    p.add_argument("--no-adc", action="store_true", help="boot with the ADS1115 disconnected")
    p.add_argument("--no-imu", action="store_true", help="boot with the BNO055 disconnected")
    p.add_argument(
        "--reset-after-model-bytes",
        type=int,
        default=None,
        metavar="N",
        help="cut the power after N bytes of a model write reach the EEPROM",
    )
    add_json_options(p, "the board's URL (one line, before it serves)")
    p.add_argument(
        "--duration", type=float, default=None, metavar="S", help="stop after S seconds (default: run until Ctrl-C)"
    )
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import math

    from porosense.emulator import Emulator, Faults
    from porosense.errors import InputError

    if args.duration is not None and not (math.isfinite(args.duration) and args.duration >= 0):
        raise InputError(f"--duration {args.duration:g}: give a number of seconds >= 0")
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise InputError(f"--speed {args.speed:g}: the time factor must be positive")
    port = args.listen.rsplit(":", 1)[-1] if args.listen.startswith("tcp://") else None
    if port is not None and not (port.isdigit() and 0 <= int(port) <= 65535):
        raise InputError(f"--listen {args.listen}: the TCP port must be 0..65535")
    try:
        faults = Faults(
            rx_corrupt=args.corrupt,
            tx_corrupt=args.corrupt,
            rx_drop=args.drop,
            tx_drop=args.drop,
            seed=args.seed,
            adc_disconnect=args.no_adc,
            imu_disconnect=args.no_imu,
            reset_after_model_bytes=args.reset_after_model_bytes,
        )
    except ValueError as exc:
        raise InputError(str(exc)) from None
    physics = load_params(args)
    plant = None
    if physics is not None:
        from porosense.sim import make_plant

        plant = make_plant(args.actuator, porosity=args.porosity, load_g=args.load_g, seed=args.seed, physics=physics)
    emu = Emulator(
        args.actuator,
        porosity=args.porosity,
        load_g=args.load_g,
        seed=args.seed,
        plant=plant,
        listen=args.listen,
        realtime=args.realtime,
        speed=args.speed,
        faults=faults,
    )
    mode = f"real time x{args.speed:g}" if args.realtime else "lockstep (as fast as the host reads)"
    announcement = {"url": emu.url, "actuator": args.actuator, "mode": mode}
    if args.json:  # one line that scripts can read before connecting
        import json

        print(json.dumps(announcement), flush=True)
    if getattr(args, "json_out", None):
        emit_json(announcement, argparse.Namespace(json=False, json_out=args.json_out))
    if not args.json:
        print(f"porosense emulator: {args.actuator} board at {emu.url} ({mode}); Ctrl-C stops", flush=True)
    if args.duration is None:
        emu.serve_forever()
        return 0
    emu.start()
    try:
        time.sleep(args.duration)
    finally:
        emu.stop()
    if emu.error is not None:
        print(f"porosense emulator: stopped by {emu.error!r}", file=sys.stderr)
        return 1
    return 0
