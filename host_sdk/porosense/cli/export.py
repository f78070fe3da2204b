"""``porosense export``: a saved model as standalone C, or as python-control transfer functions."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from porosense.cli._data import add_json_options, emit_json, load_model_checked, normalise_json_args, output_file, say
from porosense.errors import InputError


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "export",
        help="write a model as standalone C (init + step functions) or python-control transfer functions",
        description=(
            "--c writes one C file with no dependencies: a state struct, <name>_init() and <name>_step() "
            "that takes one sample of the inputs and returns the estimates, in double precision (compile with "
            "-DPOROSENSE_REAL=float for single). --python-control writes each linear block as a discrete "
            "control.TransferFunction (dt = Ts) and the static nonlinearities as breakpoints: JSON, or a "
            "pickle when the file name ends in .pkl. Units are those of the model's data."
        ),
        epilog="example: porosense export model.json --c --python-control",
    )
    p.add_argument("model", metavar="MODEL.json", help="model file (porosense identify --save)")
    p.add_argument("--c", action="store_true", help="write the C file")
    p.add_argument("--c-out", metavar="FILE.c", help="C file name (default: MODEL.c beside the model)")
    p.add_argument("--name", help="prefix of the C functions (default: porosense_<model file stem>)")
    p.add_argument("--python-control", action="store_true", help="write the transfer functions")
    p.add_argument(
        "--control-out",
        metavar="FILE.json|FILE.pkl",
        help="transfer-function file (default: MODEL_tf.json beside the model)",
    )
    add_json_options(p, "what was written")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.export import c_source, write_control

    normalise_json_args(args)
    if not (args.c or args.c_out or args.python_control or args.control_out):
        raise InputError("say what to export: --c and/or --python-control")
    model = load_model_checked(args.model)
    stem = Path(args.model).with_suffix("")
    written = {}
    if args.c or args.c_out:
        path = output_file(args.c_out or f"{stem}.c", "--c-out")
        name = args.name or "porosense_" + re.sub(r"\W", "_", stem.name)
        if not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise InputError(f"--name {name!r} is not a C identifier")
        path.write_text(c_source(model.to_structure(), name))
        written["c"] = {"path": str(path), "init": f"{name}_init", "step": f"{name}_step", "state": f"{name}_state"}
        say(args, f"C source written to {path}: {name}_init(&state), then {name}_step(&state, u, y) per sample")
    if args.python_control or args.control_out:
        path = output_file(args.control_out or f"{stem}_tf.json", "--control-out")
        write_control(model, path)
        written["python_control"] = {"path": str(path)}
        say(args, f"transfer functions written to {path}")
    emit_json({"model": str(args.model), "written": written}, args)
    return 0
