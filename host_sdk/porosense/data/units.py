"""The unit of a column: as the data state it, else as docs/conventions.md names porosense's columns.

Figures label every axis with a quantity and a unit; where neither the data nor the model state
a unit, the label says so and how to give one, rather than inventing "a.u.".
"""

from __future__ import annotations

import re

# docs/conventions.md, "Units and column names of a Recording".
CONVENTION = (
    (r"t|time|t_s|time_s", "s"),
    (r"t_ms|time_ms", "ms"),
    (r"t_dev_us|t_us|time_us", "us"),
    (r"p_cmd_\d|p_\d|cmd_kpa_\d", "kPa"),
    (r"adc_\d", "counts"),
    (r"R_\d", "ohm"),
    (r"dR_\d|strain_\d", "%"),
    (r"curvature", "1/m"),
    (r"theta_x|theta_y", "deg"),
    (r"dz", "mm"),
    (r"load_g", "g"),
)
NOT_STATED = "unit not stated"
UNIT_ALIASES = {"percent": "%", "pct": "%", "kpa": "kPa"}


def normal_unit(text) -> str:
    """A stated unit as one spelling: brackets and spaces dropped, aliases (percent, pct, kpa)
    mapped, so that "[kPa]", "kpa" and "kPa" compare equal."""
    word = str(text).strip().strip("[]()").strip()
    return UNIT_ALIASES.get(word.lower(), word)


def column_unit(name: str, *stated: dict) -> str | None:
    """The unit of column ``name``: the first of the ``stated`` dicts that names it, else the
    convention for porosense's own column names (``est_X`` and ``target_X`` take X's), else None."""
    for units in stated:
        unit = (units or {}).get(name)
        if unit:
            return str(unit)
    base = re.sub(r"^(est_|target_)", "", name)
    if base != name:
        return column_unit(base, *stated)
    for pattern, unit in CONVENTION:
        if re.fullmatch(pattern, name):
            return unit
    return None


def axis_label(name: str, *stated: dict, quantity: str | None = None) -> str:
    """'strain_0 (%)': the quantity and its unit, or '(unit not stated)' when nothing states it."""
    unit = column_unit(name, *stated)
    return f"{quantity or name} ({unit if unit else NOT_STATED})"
