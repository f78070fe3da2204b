"""What a reviewer checks in every figure's text (titles, axis labels, legends), as one function.

The text is read from the matplotlib objects themselves: every PNG porosense writes carries its
labels (porosense.files.save_figure), so a page's figures are checked from the files it shows.
"""

from __future__ import annotations

import re

# Units that are not units: an axis that says one of these has no unit.
NOT_UNITS = ("a.u.", "unit of the data", "output unit", "unit not stated", "?")
UNIT = re.compile(r"\(([^()]*(?:\([^()]*\))?[^()]*)\)\s*$")
# Axes whose quantity is a count or a category, not a measured value with a unit.
CATEGORY_LABELS = ("recording", "dataset", "sample")


def problems(labels: dict, where: str = "") -> list[str]:
    """Every problem of one figure's text (empty when a reviewer would accept it)."""
    out = []
    texts = [labels.get("title", "")]
    for k, ax in enumerate(labels.get("axes", [])):
        tag = f"{where} axes {k} ({ax.get('title') or ax.get('ylabel')})"
        texts += [ax.get("title", ""), ax.get("xlabel", ""), ax.get("ylabel", "")] + ax.get("legend", [])
        for axis in ("xlabel", "ylabel"):
            text = ax.get(axis, "")
            if not text or text in CATEGORY_LABELS:
                continue
            m = UNIT.search(text)
            if not m:
                out.append(f"{tag}: {axis} '{text}' has no unit in parentheses")
            elif any(bad == m.group(1).strip() or m.group(1).strip().startswith(bad) for bad in NOT_UNITS):
                out.append(f"{tag}: {axis} '{text}' names no unit")
        for entry in ax.get("legend", []):
            if entry.startswith(("before", "nominal", "after", "with ")) and "fit" not in entry and "%" not in entry:
                out.append(f"{tag}: legend '{entry}' compares a curve with data without its fit")
    for text in texts:
        if re.search(r"\bnan\b|\binf\b", text, re.I):
            out.append(f"{where}: '{text}' prints nan or inf")
        if re.search(r"\d+\.\d{5,}", text):
            out.append(f"{where}: '{text}' prints more than 4 decimals")
    if not any(ax.get("title") for ax in labels.get("axes", [])) and not labels.get("title"):
        out.append(f"{where}: no title")
    return out


def page_problems(figure_paths) -> list[str]:
    """Problems of every figure in ``figure_paths`` (PNG files written by porosense)."""
    from porosense.report.figures import read_labels

    out = []
    for path in figure_paths:
        labels = read_labels(path)
        if not labels:
            out.append(f"{path}: no labels stored (not written by porosense.files.save_figure)")
            continue
        out += problems(labels, str(getattr(path, "name", path)))
    return out
