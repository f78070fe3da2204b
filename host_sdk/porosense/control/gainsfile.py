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
    """Write the gains file (whole or not at all).

    Parameters
    ----------
    path : str or Path
        The JSON file to write.
    gains : PiGains
        The gains.
    plant : Fopdt or None
        The plant they were tuned for.
    rule : str
        The tuning rule in words.
    tau_cl_s : float or None
        Closed-loop time constant asked for, s.
    output : str
        Name of the controlled output.
    predicted : dict or None
        Figures of the predicted step (settling_s, overshoot_pct, ...).
    sources : sequence of str or Path
        The recordings the plant was fitted to.

    Returns
    -------
    dict
        The document written.
    """
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
    """Read a gains file.

    Parameters
    ----------
    path : str or Path
        A file written by ``save_gains`` (``porosense control tune``).

    Returns
    -------
    gains : PiGains
        The gains.
    doc : dict
        The whole document (plant, rule, output, predicted step).

    Raises
    ------
    InputError
        A missing file, not JSON, not a gains file, another version, or malformed gains.
    """
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
