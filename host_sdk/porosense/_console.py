"""The ``porosense`` console script: Ctrl-C at any point of start-up ends in one line, exit 130.

The script that pip writes imports this module, then runs a few lines of its own before it calls
:func:`run`; a Ctrl-C there would print Python's traceback. So this module, as soon as it is
imported, makes SIGINT end the process quietly; :func:`run` hands SIGINT back to Python (a
KeyboardInterrupt the command line reports and cleans up after) once the command line is loaded.
"""

import os
import signal
import sys

INTERRUPTED_EXIT = 130


def _interrupted_while_starting(signum, frame):
    sys.stderr.write("porosense: interrupted\n")
    sys.stderr.flush()
    os._exit(INTERRUPTED_EXIT)  # nothing to clean up yet: no command has run


if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not where SIGINT is ignored
    signal.signal(signal.SIGINT, _interrupted_while_starting)


def run() -> None:
    """Import the command line and run it."""
    from porosense.cli import main

    if signal.getsignal(signal.SIGINT) is _interrupted_while_starting:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.exit(main())
