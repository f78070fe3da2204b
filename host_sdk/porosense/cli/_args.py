"""Argument parsers and choices shared by the subcommands."""

from __future__ import annotations

import argparse

from porosense.errors import InputError

#: The simulated actuators, as porosense.sim.ACTUATORS names them (written out so that --help does
#: not load the simulator; tests/cli/test_actuator_names.py holds the two equal).
ACTUATORS = ("contractor", "bending", "3dof")


def add_params_option(p) -> None:
    """--params PARAMS.json: the simulated actuator's parameters (porosense calibrate)."""
    p.add_argument(
        "--params",
        metavar="PARAMS.json",
        help="parameters of a simulated actuator (from porosense calibrate; default: the built-in ones)",
    )


def load_params(args):
    """The porosense.sim.Physics of --params, or None without it.

    A parameter file extended by a cause (``diagnose --sim ... --save-extended``) is refused in
    one line: the simulated boards run a plant's physics, not the extension's effects, and
    running the file without them would be another simulator than the one it names.
    """
    if not getattr(args, "params", None):
        return None
    import json
    from pathlib import Path

    from porosense.errors import InputError
    from porosense.sim import Physics

    physics = Physics.load(args.params)
    try:
        effects = json.loads(Path(args.params).read_text()).get("effects") or {}
    except (ValueError, AttributeError):
        effects = {}
    if effects:
        raise InputError(
            f"--params {args.params} is extended by {', '.join(sorted(effects))} (diagnose --save-extended): "
            "the simulated boards run calibrated physics only; 'porosense simulate --params' runs the extension, "
            "or give the calibrated file"
        )
    return physics


def parse_range(text: str | None) -> slice | None:
    """'A:B' (Python slice semantics, either side may be empty) -> slice; None stays None."""
    if text is None:
        return None
    parts = text.split(":")
    if len(parts) != 2:
        raise InputError(f"sample range '{text}' must look like A:B (for example 0:3000 or 3000:)")
    try:
        a, b = (int(p) if p.strip() else None for p in parts)
    except ValueError:
        raise InputError(f"sample range '{text}': A and B must be integers") from None
    return slice(a, b)


def parse_columns(text: str, what: str) -> list[str]:
    """'a,b,c' -> ['a', 'b', 'c']; ``what`` names the option in the error."""
    cols = [c.strip() for c in text.split(",") if c.strip()]
    if not cols:
        raise InputError(f"--{what} needs at least one column name")
    return cols


DEPRECATED_UNTIL = "0.3"  # old spellings are accepted for one more release (docs/cli.md)


def warn(prog: str, text: str) -> None:
    """One warning line on stderr: 'porosense COMMAND: warning: ...'."""
    import sys

    print(f"{prog}: warning: {text}", file=sys.stderr)


def deprecation(prog: str, old: str, new: str) -> None:
    """The one line an old spelling prints."""
    warn(prog, f"{old} is deprecated, write {new} (accepted until {DEPRECATED_UNTIL})")


class DeprecatedOption(argparse.Action):
    """An old option spelling: stores into the new option's destination and prints one deprecation line."""

    def __init__(self, option_strings, dest, new: str = "", **kwargs):
        self.new = new
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        deprecation(parser.prog, option_string, self.new)
        setattr(namespace, self.dest, True if self.nargs == 0 else values)


def add_deprecated(p, old: str, new: str, dest: str, nargs=None, type=None) -> None:
    """Accept ``old`` (hidden from --help) as a spelling of ``new`` (whose destination is ``dest``)."""
    kwargs = {"type": type} if type is not None else {}
    if nargs is not None:
        kwargs["nargs"] = nargs
    p.add_argument(
        old, dest=dest, action=DeprecatedOption, new=new, help=argparse.SUPPRESS, default=argparse.SUPPRESS, **kwargs
    )


def add_legacy_positional(p, dest: str, nargs: str = "?") -> None:
    """A positional argument an old release took, hidden from --help (see :func:`take_positional`)."""
    p.add_argument(f"legacy_{dest}", nargs=nargs, default=None, help=argparse.SUPPRESS)


def take_positional(args, dest: str, option: str, required: bool = True):
    """Fold a legacy positional ``legacy_<dest>`` into ``args.<dest>`` with a deprecation line.

    Raises InputError when both spellings are given, or neither and ``required``."""
    old = getattr(args, f"legacy_{dest}", None)
    if old in (None, []):
        old = None
    new = getattr(args, dest, None)
    if old is not None and new not in (None, []):
        raise InputError(f"give {option} once (the positional spelling is the old one)")
    if old is not None:
        prog = f"porosense {getattr(args, 'command', '')}".strip()
        if getattr(args, "control_command", None):
            prog += f" {args.control_command}"
        deprecation(prog, f"the positional {option.lstrip('-').upper()}", f"{option} {option.lstrip('-').upper()}")
        setattr(args, dest, old)
    if required and getattr(args, dest, None) in (None, []):
        raise InputError(f"{option} is required")
    return getattr(args, dest)


def columns(values, what: str, args=None) -> list[str]:
    """Column names of ``--input``/``--output`` (space-separated; the old 'A,B' spelling with a
    deprecation line). ``values`` is a list (nargs='+') or a string."""
    if values is None:
        return []
    items = [values] if isinstance(values, str) else list(values)
    if any("," in v for v in items) and args is not None:
        prog = f"porosense {getattr(args, 'command', '')}".strip()
        deprecation(prog, f"--{what} A,B", f"--{what} A B")
    cols = [c.strip() for v in items for c in v.split(",") if c.strip()]
    if not cols:
        raise InputError(f"--{what} needs at least one column name")
    return cols
