"""The ``porosense`` console script: Ctrl-C while the command line loads ends in one line, exit 130."""

import sys


def run() -> None:
    """Import the command line and run it; a Ctrl-C during the import is reported like any other."""
    try:
        from porosense.cli import main
    except KeyboardInterrupt:
        print("porosense: interrupted", file=sys.stderr)
        sys.exit(130)
    sys.exit(main())
