"""``porosense export``: a saved model as standalone C, or as python-control transfer functions."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from porosense.cli._args import add_legacy_positional, take_positional
from porosense.cli._data import add_json_options, emit_json, load_model_checked, normalise_json_args, output_file, say
from porosense.errors import InputError
from porosense.files import write_text


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "export",
        help="write a model as standalone C, python-control transfer functions or MATLAB variables",
        description=(
            "--c writes one C file with no dependencies: a state struct, <name>_init() and <name>_step() "
            "that takes one sample of the inputs and returns the estimates, in double precision (compile with "
            "-DPOROSENSE_REAL=float for single). --python-control writes each linear block as a discrete "
            "control.TransferFunction (dt = Ts) and the static nonlinearities as breakpoints: JSON, or a "
            "pickle when the file name ends in .pkl. --mat writes each block's numerator and denominator, the "
            "static maps' breakpoints, the delays and Ts as MATLAB variables (docs/matlab.md rebuilds idtf and "
            "idnlhw objects from them). --out names the file when one format is asked for; by default each goes "
            "beside the model (MODEL.c, MODEL_tf.json, MODEL.mat). Units are those of the model's data."
        ),
        epilog="example: porosense export --model model.json --c --python-control --mat",
    )
    p.add_argument("--model", metavar="MODEL.json", help="model file (porosense identify --out)")
    add_legacy_positional(p, "model")
    p.add_argument("--c", action="store_true", help="write the C file")
    p.add_argument("--c-out", metavar="FILE.c", help="C file name (default: MODEL.c beside the model)")
    p.add_argument("--name", help="prefix of the C functions (default: porosense_<model file stem>)")
    p.add_argument("--python-control", action="store_true", help="write the transfer functions")
    p.add_argument(
        "--control-out",
        metavar="FILE.json|FILE.pkl",
        help="transfer-function file (default: MODEL_tf.json beside the model)",
    )
    p.add_argument("--mat", action="store_true", help="write the blocks as MATLAB variables (a v5 .mat file)")
    p.add_argument("--out", metavar="FILE", help="the file to write when one format is asked for")
    p.add_argument("--force", action="store_true", help="replace files already there")
    add_json_options(p, "what was written")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from porosense.export import c_source, write_control

    take_positional(args, "model", "--model")
    normalise_json_args(args)
    formats = [
        f
        for f, on in (
            ("c", args.c or args.c_out),
            ("python-control", args.python_control or args.control_out),
            ("mat", args.mat),
        )
        if on
    ]
    if not formats:
        raise InputError("say what to export: --c, --python-control and/or --mat")
    if args.out and len(formats) > 1:
        raise InputError(f"--out names one file; {len(formats)} formats were asked for ({', '.join(formats)})")
    if args.out:
        if formats == ["c"]:
            args.c_out = args.c_out or args.out
        elif formats == ["python-control"]:
            args.control_out = args.control_out or args.out
    stem = Path(args.model).with_suffix("")
    paths = {
        "c": output_file(args.c_out or f"{stem}.c", "--c-out", force=args.force) if "c" in formats else None,
        "python-control": output_file(args.control_out or f"{stem}_tf.json", "--control-out", force=args.force)
        if "python-control" in formats
        else None,
        "mat": output_file(args.out or f"{stem}.mat", "--out", force=args.force) if "mat" in formats else None,
    }
    model = load_model_checked(args.model)
    written = {}
    if args.c or args.c_out:
        path = paths["c"]
        name = args.name or "porosense_" + re.sub(r"\W", "_", stem.name)
        if not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise InputError(f"--name {name!r} is not a C identifier")
        write_text(path, c_source(model.to_structure(), name))
        written["c"] = {"path": str(path), "init": f"{name}_init", "step": f"{name}_step", "state": f"{name}_state"}
        say(args, f"C source written to {path}: {name}_init(&state), then {name}_step(&state, u, y) per sample")
    if args.python_control or args.control_out:
        path = paths["python-control"]
        write_control(model, path)
        written["python_control"] = {"path": str(path)}
        say(args, f"transfer functions written to {path}")
    if args.mat:
        from porosense.export import write_mat

        path = paths["mat"]
        write_mat(model, path)
        written["mat"] = {"path": str(path), "variable": "porosense_model"}
        say(args, f"MATLAB variables written to {path}: load it and rebuild the model with docs/matlab.md")
    emit_json({"model": str(args.model), "written": written}, args)
    return 0
