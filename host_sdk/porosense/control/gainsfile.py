"""The gains file: what ``porosense control tune`` writes and ``porosense control run`` reads.

JSON with ``format`` ("porosense-control-gains"), ``version``, ``gains`` (the ControlGains
fields), ``plant`` (the FOPDT), ``rule`` (the tuning rule in words), ``tau_cl_s``, the
``output`` name and unit, and ``predicted`` (settling time and overshoot of the predicted step).
"""

from __future__ import annotations

import json
from pathlib import Path

from porosense.control.plant import Fopdt
from porosense.control.tuning import PiGains
from porosense.errors import InputError
from porosense.files import write_text

FORMAT = "porosense-control-gains"
VERSION = 1


def save_gains(
    path,
    gains: PiGains,
    *,
    plant: Fopdt | None = None,
    rule: str = "",
    tau_cl_s=None,
    output: str = "",
    predicted: dict | None = None,
    sources=(),
) -> dict:
    """Write the gains file; returns the document written."""
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "gains": gains.to_dict(),
        "rule": rule,
        "tau_cl_s": tau_cl_s,
        "output": output,
        "plant": plant.to_dict() if plant else None,
        "predicted": predicted or {},
        "sources": [str(s) for s in sources],
    }
    write_text(path, json.dumps(doc, indent=1) + "\n")
    return doc


def load_gains(path) -> tuple[PiGains, dict]:
    """(gains, whole document) from a gains file; InputError for anything else."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"gains file {path} not found") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"gains file {path}: not JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(f"{path} is not a gains file (make one with 'porosense control tune')")
    if doc.get("version") != VERSION:
        raise InputError(f"{path}: gains file version {doc.get('version')}, this build reads {VERSION}")
    try:
        g = doc["gains"]
        gains = PiGains(float(g["kp_kpa"]), float(g["ki_kpa_per_s"]), float(g["slew_per_s"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: malformed gains ({exc})") from None
    return gains, doc
