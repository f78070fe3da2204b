"""A model's blocks as python-control objects, and their file forms (JSON or pickle)."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np

from porosense.files import write_bytes, write_text


def control_blocks(model) -> dict:
    """``{output: {"h1[input]": TransferFunction, "h2": ..., "f[input]"/"g": {"x": [...], "y": [...]}}}``.

    Transfer functions are discrete (dt = Ts in s) in the data's units, with the model's
    scalings folded in (as ``model.to_structure()``); static maps are breakpoint lists.
    """
    out = {}
    for m in getattr(model, "models", [model]):
        blocks = dict(m.linear_blocks())
        chain = m.output_chain()
        for br in chain.branches:
            if br.f is not None:
                blocks[f"f[{m.inputs[br.input]}]"] = {"x": br.f.x.tolist(), "y": br.f.y.tolist()}
        if chain.g is not None:
            blocks["g"] = {"x": chain.g.x.tolist(), "y": chain.g.y.tolist()}
        blocks["offset"] = float(chain.offset)
        out[m.output] = blocks
    return out


def _tf_dict(tf) -> dict:
    num, den = (np.asarray(v[0][0], dtype=float) for v in (tf.num, tf.den))
    return {
        "num": num.tolist(),
        "den": den.tolist(),
        "dt": float(tf.dt),
        "form": "coefficients of descending powers of z (control.tf(num, den, dt))",
    }


def write_control(model, path) -> Path:
    """Write :func:`control_blocks` to ``path``: a pickle for ``.pkl``/``.pickle``, else JSON."""
    path = Path(path)
    blocks = control_blocks(model)
    if path.suffix in (".pkl", ".pickle"):
        write_bytes(path, pickle.dumps(blocks))
        return path
    doc = {
        "format": "porosense.control/1",
        "ts": float(model.ts),
        "inputs": list(model.inputs),
        "outputs": {o: {k: (_tf_dict(v) if hasattr(v, "num") else v) for k, v in b.items()} for o, b in blocks.items()},
    }
    write_text(path, json.dumps(doc, indent=1))
    return path
