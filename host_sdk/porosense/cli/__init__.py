"""The ``porosense`` command.

Each subcommand lives in its own module ``porosense.cli.<name>`` exposing

    def register(subparsers) -> argparse.ArgumentParser   # adds the parser, sets func=run
    def run(args) -> int                                   # the exit status

User mistakes raise :class:`porosense.errors.PorosenseError`; ``main`` prints them as one
line on stderr and exits with the error's code, never with a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading

from porosense._version import __version__
from porosense.errors import PorosenseError

# Order is the order --help lists them in: the workflow from experiment to device.
SUBCOMMANDS = (
    "demo",
    "simulate",
    "calibrate",
    "identify",
    "predict",
    "compare",
    "compensate",
    "report",
    "export",
    "diagnose",
    "quantize",
    "flash",
    "verify",
    "control",
    "firmware",
    "config",
    "ports",
    "emulator",
    "record",
    "infoam",
    "bench",
)


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every installed subcommand."""
    parser = argparse.ArgumentParser(
        prog="porosense",
        description=(
            "Proprioception for 3D-printed graded-porosity soft vacuum actuators: simulate the "
            "paper's experiments, identify linear/Hammerstein/Wiener/Wiener-Hammerstein models "
            "of strain from resistance, quantize them, flash them to an Arduino Uno and verify "
            "them on the device."
        ),
        epilog="Run 'porosense COMMAND --help' for the options of one command.",
    )
    parser.add_argument("--version", action="version", version=f"porosense {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"porosense.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"porosense.cli.{name}":
                continue  # subcommand not part of this build
            raise
        module.register(sub)
    return parser


SIGPIPE_EXIT = 141  # 128 + SIGPIPE, what a shell reports for a tool stopped by a closed pipe
INTERRUPTED_EXIT = 130  # 128 + SIGINT, what a shell reports for a tool stopped by Ctrl-C


def _one_line(text: str) -> str:
    """``text`` with every character that is not printable (line breaks and control bytes from a
    damaged file, which a message may quote) escaped, so an error stays one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit status."""
    previous = _latch_sigint()
    try:
        return _run(argv)
    except BrokenPipeError:
        # The reader went away (`porosense ... | head`): stop quietly, as other shell tools do,
        # and keep the interpreter's final flush from writing into the closed pipe.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return SIGPIPE_EXIT
    except KeyboardInterrupt:  # before a command started: while the parser was being built
        return _interrupted("porosense")
    except Exception:
        if _sigint_seen.is_set():
            return _interrupted("porosense")
        raise
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
            sys.unraisablehook = _hooks_before.pop()


# Set once Ctrl-C arrived. A C extension that is being imported when the KeyboardInterrupt is
# raised (numpy's, importing datetime) reports it as an ImportError; any error after Ctrl-C is the
# interrupt's consequence and ends as one.
_sigint_seen = threading.Event()


def _raise_interrupt(signum, frame):
    _sigint_seen.set()
    raise KeyboardInterrupt


#: the unraisable hooks in place before each running command's (restored when it ends)
_hooks_before: list = []
#: delay of a swallowed Ctrl-C's second delivery, s (long enough for the hook to have returned)
REDELIVER_S = 0.05


def _redeliver_swallowed_interrupt(hook_args):
    """sys.unraisablehook while a command runs: a Ctrl-C that landed in a callback which cannot
    raise (a weakref callback of the import system, a __del__) is swallowed by the interpreter and
    the command would run on; the signal is sent again, from another thread a moment later, so that
    it lands after this hook returned, where it can stop the command."""
    if isinstance(hook_args.exc_value, KeyboardInterrupt):
        again = threading.Timer(REDELIVER_S, os.kill, (os.getpid(), signal.SIGINT))
        again.daemon = True
        again.start()
        return
    (_hooks_before[-1] if _hooks_before else sys.__unraisablehook__)(hook_args)


def _latch_sigint():
    """Route Ctrl-C through :func:`_raise_interrupt`; returns the handler to restore, or None when
    SIGINT is not Python's default here (ignored by the caller, or not the main thread)."""
    _sigint_seen.clear()
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.default_int_handler:
        return None
    signal.signal(signal.SIGINT, _raise_interrupt)
    _hooks_before.append(sys.unraisablehook)
    sys.unraisablehook = _redeliver_swallowed_interrupt
    return previous


def _interrupted(who: str) -> int:
    """One line for Ctrl-C; a second Ctrl-C while it is printed is ignored."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    print(f"{who}: interrupted", file=sys.stderr)
    return INTERRUPTED_EXIT


def _run(argv: list[str] | None) -> int:
    from porosense.cli._outputs import OutputGuard

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    who = f"porosense {args.command}"
    guard = OutputGuard(args)
    try:
        with guard:
            status = int(args.func(args) or 0)
    except KeyboardInterrupt:
        return _interrupted(who)
    except Exception as exc:
        if _sigint_seen.is_set():
            return _interrupted(who)
        if isinstance(exc, PorosenseError):
            print(f"{who}: error: {_one_line(str(exc))}", file=sys.stderr)
            return exc.exit_code
        raise
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
