"""``porosense calibrate``: fit the simulator's parameters to measured recordings."""

from __future__ import annotations

import argparse

from porosense.cli._args import ACTUATORS, parse_range
from porosense.cli._data import add_data_options, add_json_options, emit_json, output_file, say

MATERIAL = "material"
LOAD_COLUMN = "load_g"  # the recordings' hanging load (g), as porosense.sim.experiment writes it


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "calibrate",
        help="fit the simulator's parameters to recordings (an actuator's, or a tensile test's)",
        description=(
            "Fit the simulator to measurements and write its parameter file (JSON), which "
            "simulate, emulator, simboard, demo and control take with --params. ACTUATOR: "
            "recordings of commanded vacuum (p_cmd_C, kPa), dR_C (%) and, where present, the "
            "measured outputs (strain_0 %, curvature 1/m, theta_x/theta_y deg, dz mm) of one "
            "print. material: a tensile test (strain imposed, resistance and time measured); the "
            "piezoresistive law is fitted with each recording's own R0 and R0 drift, on the "
            "samples of --estimation A:B (the rest is held out and scored). A recording with a "
            "load column (load_g, g; --load-column COL) was made under that hanging load: it is "
            "simulated under it, so the fitted physics is the unloaded print's, and the parameter "
            "file names the column (simulate --params --replay reads it)."
        ),
        epilog=(
            "examples: porosense calibrate contractor --data rec1.csv rec2.csv --out params.json; "
            "porosense calibrate material --data tensile.csv --strain strain --resistance R "
            "--estimation 0:3000 --out law.json"
        ),
    )
    p.add_argument("actuator", choices=(*ACTUATORS, MATERIAL), help="which actuator, or the material alone")
    p.add_argument("--data", nargs="+", required=True, metavar="FILE", help="recordings (CSV or .mat)")
    p.add_argument("--out", required=True, metavar="PARAMS.json", help="parameter file to write")
    p.add_argument("--force", action="store_true", help="replace an existing --out")
    p.add_argument("--strain", metavar="COL", help="material: the strain column (%% unless the file states 1)")
    p.add_argument("--resistance", metavar="COL", help="material: the resistance column (ohm)")
    p.add_argument("--estimation", metavar="A:B", help="material: estimation samples of each recording (default: all)")
    p.add_argument("--ablation", action="store_true", help="material: refit without each effect and report it")
    p.add_argument(
        "--load-column",
        metavar="COL",
        help="ACTUATOR: the recordings' hanging-load column in g (default load_g); each record that has it is "
        "simulated under that load during the fit, the others unloaded",
    )
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_data_options(p)
    add_json_options(p, "the calibration's figures")
    p.set_defaults(func=run)
    return p


def strain_fraction(table, col: str):
    """The strain column as a fraction: % unless the file states the unit as 1 or fraction."""
    unit = str(table.units.get(col, "%")).strip().lower()
    return table[col] / (1.0 if unit in ("1", "fraction", "-") else 100.0)


def time_axis(table, ts: float):
    import numpy as np

    if table.time is not None:
        return np.asarray(table.time, dtype=float)
    return np.arange(len(table)) * ts


def material_records(tables, args, ts: float, estimation=None):
    import numpy as np

    from porosense.cli._data import require_columns
    from porosense.sim.calibrate import MaterialRecord

    out = []
    for table in tables:
        require_columns(table, [args.strain, args.resistance])
        mask = np.zeros(len(table), bool)
        mask[estimation if estimation is not None else slice(None)] = True
        out.append(
            MaterialRecord(
                time_axis(table, ts), strain_fraction(table, args.strain), table[args.resistance], mask, str(table.path)
            )
        )
    return out


def actuator_record(table, actuator: str, ts: float, load_column: str | None = None):
    """The table as a porosense.sim.calibrate.ActuatorRecord: ``p_cmd_C`` (kPa), ``dR_C`` (%),
    the actuator's outputs the table has and, with ``load_column``, the load during it (g; a table
    without that column, or with it in another stated unit, is refused in one line)."""
    import numpy as np

    from porosense.cli._data import require_columns
    from porosense.sim import OUTPUTS
    from porosense.sim.calibrate import ActuatorRecord

    n = 3 if actuator == "3dof" else 1
    p_cols = [f"p_cmd_{c}" for c in range(n)]
    dr_cols = [f"dR_{c}" for c in range(n)]
    require_columns(table, p_cols + dr_cols)
    outputs = {k: table[k] for k in OUTPUTS[actuator] if k in table.columns}
    load = None
    if load_column is not None:
        from porosense.data.units import normal_unit
        from porosense.errors import InputError

        if load_column not in table.columns:
            raise InputError(
                f"{table.path} has no column '{load_column}': the parameter file's load_dependence takes the "
                "load during the record (g) from it"
            )
        unit = table.units.get(load_column)
        if unit and normal_unit(unit) != "g":
            raise InputError(f"{table.path}: column '{load_column}' is in {unit}; the simulator takes the load in g")
        load = np.asarray(table[load_column], dtype=float)
        bad = np.flatnonzero(~(np.isfinite(load) & (load >= 0.0)))
        if bad.size:
            raise InputError(
                f"{table.path}: column '{load_column}' has {load[bad[0]]:g} g at sample {bad[0]} (a load is a "
                "finite mass >= 0 g)"
            )
    return ActuatorRecord(
        np.column_stack([table[c] for c in p_cols]),
        ts,
        np.column_stack([table[c] for c in dr_cols]),
        outputs,
        name=str(table.path),
        load_g=load,
    )


def run(args) -> int:
    from porosense.cli._data import read_tables, sample_period
    from porosense.errors import InputError

    out = output_file(args.out, "--out", force=args.force)
    if args.actuator == MATERIAL and not (args.strain and args.resistance):
        raise InputError("calibrate material needs --strain COL and --resistance COL")
    if args.actuator == MATERIAL and args.load_column:
        raise InputError("--load-column names an actuator recording's hanging load: calibrate material has none")
    tables = read_tables(args.data, args)
    ts = sample_period(tables, args)
    if args.actuator == MATERIAL:
        from porosense.sim.calibrate import calibrate_material

        cal = calibrate_material(
            material_records(tables, args, ts, parse_range(args.estimation)), ablation=args.ablation
        )
        cal.physics = cal.physics.with_(piezo={"r0_ohm": float(sum(cal.r0_ohm) / len(cal.r0_ohm))})
        cal.physics.save(out, fit=cal.to_dict())
    else:
        from porosense.sim.calibrate import calibrate_actuator

        column = args.load_column or LOAD_COLUMN
        has = [column in t.columns for t in tables]
        if args.load_column and not any(has):
            raise InputError(f"--load-column {column}: no recording has that column (g)")
        if not args.quiet and not all(has):
            bare = [str(t.path) for t, h in zip(tables, has) if not h]
            what = "no recording has a" if not any(has) else f"{len(bare)} of {len(tables)} recordings have no"
            say(args, f"{what} load column '{column}' (g): calibrated unloaded ({', '.join(bare)})")
        records = [actuator_record(t, args.actuator, ts, column if h else None) for t, h in zip(tables, has)]
        cal = calibrate_actuator(args.actuator, records, load_column=column)
        cal.save(out)
    if not args.quiet:
        say(args, str(cal))
        say(args, f"wrote {out}")
    emit_json({"params": str(out), **cal.to_dict()}, args)
    return 0
