"""Argument parsers and choices shared by the subcommands."""

from __future__ import annotations

from porosense.errors import InputError

#: The simulated actuators, as porosense.sim.ACTUATORS names them (written out so that --help does
#: not load the simulator; tests/cli/test_actuator_names.py holds the two equal).
ACTUATORS = ("contractor", "bending", "3dof")


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
