"""``porosense infoam``: print planning for graded-porosity actuators (the InFoam method)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from porosense.cli._args import add_deprecated
from porosense.cli._data import add_json_options, emit_json
from porosense.errors import InputError
from porosense.files import write_text


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "infoam",
        help="plan prints of graded-porosity actuators (calibrate, G-code, predict)",
        description=(
            "Print planning by liquid rope coiling. Coil radius Rc (mm) follows nozzle height H (mm) as "
            "Rc = a H + b; porosity (%) follows coil geometry, calibrated on weighed cubes "
            "(phi = 100 (1 - m / (V rho_b))). A design is a set of regions of target porosity; the planner "
            "turns it into G-code and the simulator predicts stroke and dR at each vacuum level."
        ),
        epilog=(
            "examples:\n"
            "  porosense infoam calibrate --json\n"
            "  porosense infoam design contractor --foam-porosity 82 --out my_contractor.json\n"
            "  porosense infoam gcode contractor --machine pellet-ender5plus --out contractor.gcode --preview c.png\n"
            "  porosense infoam gcode bending --machine pellet-ender5plus --out bending.gcode\n"
            "  porosense infoam gcode segment --out segment.gcode   # the 3-DoF segment's three contractors\n"
            "  porosense infoam parts --out parts/                   # PLA holders and frames as STL\n"
            "  porosense infoam plan segment --out build/            # everything the 3-DoF segment needs\n"
            "  porosense infoam machines\n"
            "  porosense infoam figures --out docs/figures\n"
            "  porosense infoam predict contractor --load 200"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    s = p.add_subparsers(dest="infoam_command", metavar="STEP", required=True)

    c = s.add_parser(
        "calibrate",
        help="fit Rc = a H + b and the porosity model",
        description="Fit the coil-radius line and the porosity model. Without files, the paper's "
        "cTPE values are used (Rc = 0.40 H - 0.3 mm; H = 4, 6, 8, 10 mm at N = 3 "
        "gave 68, 76, 82, 86 %).",
    )
    c.add_argument("--coil-radii", metavar="CSV", help="columns height_mm, radius_mm (measured coil radii)")
    c.add_argument(
        "--cubes", metavar="CSV", help="columns height_mm, coil_density, and either porosity_pct or mass_g + volume_mm3"
    )
    c.add_argument("--bulk-density", type=float, default=0.97, help="g/cm^3 (default 0.97, cTPE)")
    c.add_argument("--nozzle", type=float, default=0.6, help="nozzle diameter in mm (default 0.6)")
    c.add_argument("--out", metavar="CAL.json", help="write the calibration for 'infoam gcode --calibration'")
    add_deprecated(c, "--save", "--out", "out")
    add_json_options(c, "the calibration")
    c.set_defaults(func=run_calibrate)

    d = s.add_parser("design", help="write a built-in example design as editable JSON")
    d.add_argument("example", choices=("contractor", "bending", "segment"))
    d.add_argument(
        "--foam-porosity",
        type=float,
        help="porosity of the foam sections in %% (default 76 for the contractor, 84 for the bending actuator)",
    )
    d.add_argument("--out", required=True, help="design JSON to write")
    d.set_defaults(func=run_design)

    g = s.add_parser(
        "gcode",
        help="plan a design and write its G-code",
        description="Plan every region and write G-code (absolute XYZ, relative E, mm). "
        "Foam regions are coiled at the nozzle height that gives their porosity.",
    )
    g.add_argument("design", help="design JSON, or a built-in example: contractor, bending, segment")
    g.add_argument("--out", required=True, help="G-code file to write")
    g.add_argument(
        "--machine",
        default="pellet-ender5plus",
        help="machine profile: a built-in name (see 'infoam machines') or a TOML file "
        "(default pellet-ender5plus, the paper's printer)",
    )
    g.add_argument("--preview", metavar="PNG", help="also draw the toolpath coloured by porosity")
    g.add_argument("--calibration", metavar="CAL.json", help="calibration from 'infoam calibrate --out'")
    g.add_argument("--coil-density", type=float, default=3.0, help="coils per coil diameter of travel (default 3)")
    add_json_options(g, "the plan")
    g.set_defaults(func=run_gcode)

    m = s.add_parser(
        "machines",
        help="list the built-in machine profiles, or check a profile file",
        description="List the built-in machine profiles. With a name or TOML file, validate it and "
        "print it (exit 2 with one line naming the problem when it is wrong).",
    )
    m.add_argument("profile", nargs="?", help="profile name or TOML file to check")
    add_json_options(m, "the machine profile(s)")
    m.set_defaults(func=run_machines)

    pa = s.add_parser(
        "parts",
        help="write the PLA holders and frames as STL",
        description="Write the printable fixtures as STL (mm): the bending actuator's holder, "
        "the contractor's hanger and load hook, and the 3-DoF segment's base and stage "
        "(with the BNO055 mount). Each is checked to be watertight and to fit the machine.",
    )
    pa.add_argument("--out", required=True, help="folder to write the STL files into (created if absent)")
    pa.add_argument(
        "--machine",
        default="filament-ender5plus",
        help="machine the PLA parts are printed on, for the bed-size check (default filament-ender5plus)",
    )
    pa.add_argument("--only", nargs="+", metavar="PART", help="write only these parts")
    add_json_options(pa, "the part list")
    pa.set_defaults(func=run_parts)

    pl = s.add_parser(
        "plan",
        help="the full build of an actuator: its G-code, its fixtures and a plan.json",
        description="Write everything an actuator needs: the cTPE G-code for the pellet printer, "
        "the PLA fixtures as STL, previews, and plan.json listing every item with its "
        "material, machine, mass and what it is for.",
    )
    pl.add_argument("actuator", choices=("contractor", "bending", "segment"))
    pl.add_argument("--out", required=True, help="folder to write into (created if absent)")
    pl.add_argument(
        "--machine", default="pellet-ender5plus", help="machine for the cTPE print (default pellet-ender5plus)"
    )
    pl.add_argument(
        "--fixture-machine",
        default="filament-ender5plus",
        help="printer for the PLA fixtures, for the bed-size check (default filament-ender5plus)",
    )
    add_json_options(pl, "plan.json")
    pl.set_defaults(func=run_plan)

    f = s.add_parser(
        "figures",
        help="draw the assembly guide's figures (docs/assembly.md)",
        description="Draw the figures of docs/assembly.md from the designs, plans and meshes.",
    )
    f.add_argument("--out", required=True, help="folder for the PNG files (created if absent)")
    f.set_defaults(func=run_figures)

    r = s.add_parser("predict", help="expected stroke and dR at -10, -20, -40, -60 kPa")
    r.add_argument("design", help="design JSON, or a built-in example: contractor, bending, segment")
    r.add_argument("--load-g", type=float, default=0.0, metavar="GRAMS", help="external load in g (default 0)")
    add_deprecated(r, "--load", "--load-g", "load_g", type=float)
    add_json_options(r, "the prediction")
    r.set_defaults(func=run_predict)
    return p


def run(args) -> int:  # pragma: no cover - argparse dispatches to the step functions
    return args.func(args)


def _calibration(args):
    import numpy as np

    from porosense.data import read_table
    from porosense.infoam import PAPER_COIL_RADIUS, CoilRadiusFit, PorosityModel, paper_calibration, porosity_from_mass
    from porosense.infoam.calibration import PAPER_COIL_DENSITY, PAPER_HEIGHTS_MM, PAPER_POROSITIES_PCT

    coil = PAPER_COIL_RADIUS
    if args.coil_radii:
        t = read_table(args.coil_radii)
        if not (np.all(t["height_mm"] > 0) and np.all(t["radius_mm"] > 0)):
            raise InputError(f"{args.coil_radii}: heights and coil radii must be positive (mm)")
        coil = CoilRadiusFit.fit(t["height_mm"], t["radius_mm"])
    if args.cubes:
        t = read_table(args.cubes)
        h = t["height_mm"]
        n = t["coil_density"] if "coil_density" in t else np.full(len(h), PAPER_COIL_DENSITY)
        if "porosity_pct" in t:
            phi = t["porosity_pct"]
        else:
            phi = np.array([porosity_from_mass(m, v, args.bulk_density) for m, v in zip(t["mass_g"], t["volume_mm3"])])
        return PorosityModel.fit(h, phi, n, nozzle_mm=args.nozzle, coil=coil)
    if coil is PAPER_COIL_RADIUS and args.nozzle == 0.6:
        return paper_calibration()
    return PorosityModel.fit(
        PAPER_HEIGHTS_MM, PAPER_POROSITIES_PCT, PAPER_COIL_DENSITY, nozzle_mm=args.nozzle, coil=coil
    )


def run_calibrate(args) -> int:
    from porosense.infoam.calibration import PAPER_HEIGHTS_MM

    model = _calibration(args)
    data = model.to_dict()
    data["porosity_at_paper_heights"] = {f"{h:g}": float(model.porosity(h)) for h in PAPER_HEIGHTS_MM}
    if args.out:
        text = (
            json.dumps({"format": "porosense-infoam-calibration", "version": 1, "model": model.to_dict()}, indent=2)
            + "\n"
        )
        _write(args.out, lambda path: write_text(path, text))
    emit_json(data, args)
    if not args.json:
        print(f"coil radius: Rc = {model.coil.a:.4f} H {model.coil.b:+.4f} mm (R^2 {model.coil.r2:.4f})")
        print(f"porosity: solid = {model.c_mm:.4f} N / (2 Rc + {model.nozzle_mm:g} {model.e_mm:+.4f}) (mm)")
        for h, phi in data["porosity_at_paper_heights"].items():
            print(f"  H = {h:>2s} mm, N = 3: {phi:5.1f} %")
    return 0


def _load_calibration(path):
    from porosense.infoam import CoilRadiusFit, PorosityModel

    try:
        m = json.loads(Path(path).read_text())["model"]
        return PorosityModel(m["c_mm"], m["e_mm"], m["nozzle_mm"], CoilRadiusFit(**m["coil"]))
    except FileNotFoundError:
        raise InputError(f"{path}: no such calibration file") from None
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: not a calibration written by 'infoam calibrate --out' ({exc!r})") from None


def run_design(args) -> int:
    from porosense.infoam import paper_bending, paper_contractor

    make = paper_contractor if args.example == "contractor" else paper_bending
    design = make(args.foam_porosity) if args.foam_porosity is not None else make()
    _write(args.out, design.save)
    print(f"wrote {args.out} ({len(design.regions)} regions, foam porosity {design.foam_porosity():.1f} %)")
    return 0


def run_gcode(args) -> int:
    from porosense.infoam import PrintSettings, generate, get_design, load_machine, paper_calibration

    design = get_design(args.design)
    machine = load_machine(args.machine)
    model = _load_calibration(args.calibration) if args.calibration else paper_calibration()
    settings = PrintSettings(machine=machine, porosity_model=model, coil_density=args.coil_density)
    job = generate(design, settings)
    _write(args.out, job.write)
    if args.preview:
        from porosense.infoam.preview import plot_toolpath

        _write(args.preview, lambda path: plot_toolpath(job, path))
    emit_json(job.to_dict(args.out), args)
    if not args.json:
        print("\n".join(job.summary()))
        print(f"wrote {args.out}" + (f" and {args.preview}" if args.preview else ""))
    return 0


def _write(path, writer) -> None:
    """Run ``writer(path)``; a missing folder or an unwritable path is an InputError."""
    try:
        writer(path)
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError, PermissionError) as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror or exc})") from None


def _out_dir(path) -> Path:
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError, PermissionError) as exc:
        raise InputError(f"{out}: cannot create the folder ({exc.strerror or exc})") from None
    return out


def run_machines(args) -> int:
    from porosense.infoam import list_machines, load_machine

    if args.profile:
        m = load_machine(args.profile)
        emit_json(m.to_dict(), args)
        if not args.json:
            e = m.extruder
            print(f"{m.name}: {m.description}")
            print(
                f"  build {m.build_x_mm:g} x {m.build_y_mm:g} x {m.build_z_mm:g} mm, nozzle {m.nozzle_mm:g} mm, "
                f"hotend {m.hotend_c:g} C, bed {m.bed_c:g} C, material {m.material}"
            )
            print(f"  extruder {e.kind}, E unit {e.e_unit} = {m.mm3_per_e:.4g} mm^3 of melt")
        return 0
    names = list_machines()
    emit_json(names, args)
    if not args.json:
        for name in names:
            print(f"{name:22s} {load_machine(name).description}")
    return 0


def run_parts(args) -> int:
    from porosense.infoam import load_machine
    from porosense.infoam.parts import PARTS, build_parts

    machine = load_machine(args.machine)
    names = args.only or list(PARTS)
    unknown = [n for n in names if n not in PARTS]
    if unknown:
        raise InputError(f"unknown part(s) {', '.join(unknown)}: known are {', '.join(PARTS)}")
    out = _out_dir(args.out)
    parts = build_parts(names, machine)
    rows = [p.write(out) for p in parts]
    emit_json(rows, args)
    if not args.json:
        for r in rows:
            x, y, z = r["size_mm"]
            print(
                f"{r['file']:28s} {x:6.1f} x {y:6.1f} x {z:6.1f} mm, {r['volume_cm3']:6.2f} cm^3 PLA, "
                f"watertight {r['watertight']}"
            )
        print(f"wrote {len(rows)} STL files to {out}")
    return 0


def run_plan(args) -> int:
    from porosense.infoam import load_machine
    from porosense.infoam.build import build_plan

    plan = build_plan(
        args.actuator,
        load_machine(args.machine),
        _out_dir(args.out),
        fixture_machine=load_machine(args.fixture_machine),
    )
    emit_json(plan.to_dict(), args)
    if not args.json:
        print("\n".join(plan.summary()))
    return 0


def run_figures(args) -> int:
    from porosense.infoam.figures import write_all

    for path in write_all(_out_dir(args.out)):
        print(f"wrote {path}")
    return 0


def run_predict(args) -> int:
    from porosense.infoam import get_design, predict

    if not 0 <= args.load_g <= 2000:
        raise InputError(f"--load-g {args.load_g:g} g outside 0..2000 g")
    pred = predict(get_design(args.design), load_g=args.load_g)
    emit_json(pred.to_dict(), args)
    if not args.json:
        print("\n".join(pred.summary()))
    return 0
