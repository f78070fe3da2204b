"""``porosense infoam``: print planning for graded-porosity actuators (the InFoam method)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from porosense.errors import InputError


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
            "  porosense infoam gcode my_contractor.json --out contractor.gcode --preview contractor.png\n"
            "  porosense infoam predict contractor --load 200"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    s = p.add_subparsers(dest="infoam_command", metavar="STEP", required=True)

    c = s.add_parser("calibrate", help="fit Rc = a H + b and the porosity model",
                     description="Fit the coil-radius line and the porosity model. Without files, the paper's "
                                 "cTPE values are used (Rc = 0.40 H - 0.3 mm; H = 4, 6, 8, 10 mm at N = 3 "
                                 "gave 68, 76, 82, 86 %).")
    c.add_argument("--coil-radii", metavar="CSV", help="columns height_mm, radius_mm (measured coil radii)")
    c.add_argument("--cubes", metavar="CSV",
                   help="columns height_mm, coil_density, and either porosity_pct or mass_g + volume_mm3")
    c.add_argument("--bulk-density", type=float, default=0.97, help="g/cm^3 (default 0.97, cTPE)")
    c.add_argument("--nozzle", type=float, default=0.6, help="nozzle diameter in mm (default 0.6)")
    c.add_argument("--save", metavar="CAL.json", help="write the calibration for 'infoam gcode --calibration'")
    c.add_argument("--json", action="store_true", help="print the calibration as JSON")
    c.set_defaults(func=run_calibrate)

    d = s.add_parser("design", help="write a built-in example design as editable JSON")
    d.add_argument("example", choices=("contractor", "bending"))
    d.add_argument("--foam-porosity", type=float, help="porosity of the foam sections in %% "
                   "(default 76 for the contractor, 84 for the bending actuator)")
    d.add_argument("--out", required=True, help="design JSON to write")
    d.set_defaults(func=run_design)

    g = s.add_parser("gcode", help="plan a design and write its G-code",
                     description="Plan every region and write G-code (absolute XYZ, relative E, mm). "
                                 "Foam regions are coiled at the nozzle height that gives their porosity.")
    g.add_argument("design", help="design JSON, or a built-in example: contractor, bending")
    g.add_argument("--out", required=True, help="G-code file to write")
    g.add_argument("--preview", metavar="PNG", help="also draw the toolpath coloured by porosity")
    g.add_argument("--calibration", metavar="CAL.json", help="calibration from 'infoam calibrate --save'")
    g.add_argument("--coil-density", type=float, default=3.0, help="coils per coil diameter of travel (default 3)")
    g.add_argument("--json", action="store_true", help="print the plan as JSON")
    g.set_defaults(func=run_gcode)

    r = s.add_parser("predict", help="expected stroke and dR at -10, -20, -40, -60 kPa")
    r.add_argument("design", help="design JSON, or a built-in example: contractor, bending")
    r.add_argument("--load", type=float, default=0.0, help="external load in g (default 0)")
    r.add_argument("--json", action="store_true", help="print the prediction as JSON")
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
    return PorosityModel.fit(PAPER_HEIGHTS_MM, PAPER_POROSITIES_PCT, PAPER_COIL_DENSITY, nozzle_mm=args.nozzle, coil=coil)


def run_calibrate(args) -> int:
    from porosense.infoam.calibration import PAPER_HEIGHTS_MM

    model = _calibration(args)
    data = model.to_dict()
    data["porosity_at_paper_heights"] = {f"{h:g}": float(model.porosity(h)) for h in PAPER_HEIGHTS_MM}
    if args.save:
        Path(args.save).write_text(json.dumps({"format": "porosense-infoam-calibration", "version": 1,
                                               "model": model.to_dict()}, indent=2) + "\n")
    if args.json:
        print(json.dumps(data, indent=2))
    else:
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
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: not a calibration written by 'infoam calibrate --save' ({exc!r})") from None


def run_design(args) -> int:
    from porosense.infoam import paper_bending, paper_contractor

    make = paper_contractor if args.example == "contractor" else paper_bending
    design = make(args.foam_porosity) if args.foam_porosity is not None else make()
    design.save(args.out)
    print(f"wrote {args.out} ({len(design.regions)} regions, foam porosity {design.foam_porosity():.1f} %)")
    return 0


def run_gcode(args) -> int:
    from porosense.infoam import Machine, PrintSettings, generate, get_design, paper_calibration

    design = get_design(args.design)
    model = _load_calibration(args.calibration) if args.calibration else paper_calibration()
    if not 0.5 <= args.coil_density <= 10:
        raise InputError(f"--coil-density {args.coil_density} outside 0.5..10")
    settings = PrintSettings(machine=Machine(nozzle_mm=model.nozzle_mm), porosity_model=model,
                             coil_density=args.coil_density)
    job = generate(design, settings)
    for plan in job.plans:  # a negative coil radius is a calibration that no printer can follow
        if plan.method == "coil" and not model.coil.radius(plan.nozzle_height_mm) > 0:
            raise InputError(f"region {plan.region.name}: the calibration gives a coil radius of "
                             f"{model.coil.radius(plan.nozzle_height_mm):.3g} mm at nozzle height "
                             f"{plan.nozzle_height_mm:.3g} mm; recalibrate with positive radii")
    job.write(args.out)
    if args.preview:
        from porosense.infoam.preview import plot_toolpath

        plot_toolpath(job, args.preview)
    if args.json:
        print(json.dumps({"design": design.name, "gcode": args.out,
                          "predicted_solid_volume_mm3": job.predicted_solid_volume,
                          "regions": [{"name": p.region.name, "method": p.method, "target_pct": p.region.porosity,
                                       "predicted_pct": p.porosity, "layers": p.n_layers, "layer_mm": p.layer_mm,
                                       "pitch_mm": p.pitch_mm, "nozzle_height_mm": p.nozzle_height_mm,
                                       "coil_density": p.coil_density} for p in job.plans]}, indent=2))
    else:
        print("\n".join(job.summary()))
        print(f"wrote {args.out}" + (f" and {args.preview}" if args.preview else ""))
    return 0


def run_predict(args) -> int:
    from porosense.infoam import get_design, predict

    if not 0 <= args.load <= 2000:
        raise InputError(f"--load {args.load} g outside 0..2000 g")
    pred = predict(get_design(args.design), load_g=args.load)
    if args.json:
        print(json.dumps(pred.to_dict(), indent=2))
    else:
        print("\n".join(pred.summary()))
    return 0
