"""``porosense simulate ... --replay REC``: a recording's inputs through the simulator."""

from __future__ import annotations

from pathlib import Path


def replay(args, physics, effects=None) -> int:
    """Write the simulated columns beside ``t`` and print their fit against the recording's."""
    import numpy as np

    from porosense.cli._args import parse_range
    from porosense.cli._data import emit_json, output_file, read_tables, sample_period, say
    from porosense.cli.calibrate import actuator_record, material_records, time_axis
    from porosense.data import Recording
    from porosense.data.recording import refuse_foreign_sidecar
    from porosense.dsp.metrics import fit_percent
    from porosense.errors import InputError
    from porosense.sim import OUTPUTS, Physics

    out = output_file(args.out or f"{Path(args.replay).stem}_sim.csv", "--out", force=args.force)
    sidecar = out.with_suffix(".json")  # Recording.to_csv writes the units and notes there
    refuse_foreign_sidecar(out)  # a parameter file or model of that stem: refused before any work
    if not args.force and sidecar.exists():
        raise InputError(f"{sidecar} exists (the sidecar --out {out} writes): --force replaces it")
    tables = read_tables([args.replay], args)
    ts = sample_period(tables, args)
    table = tables[0]
    t = time_axis(table, ts)
    columns, units, fits = {}, {}, {}
    if args.actuator == "material":
        if physics is None:
            raise InputError("simulate material needs --params PARAMS.json (from porosense calibrate material)")
        if not args.strain:
            raise InputError("simulate material --replay needs --strain COL")
        from porosense.cli.calibrate import strain_fraction
        from porosense.sim.calibrate import simulate_material

        if args.resistance:
            rec = material_records(tables, args, ts, parse_range(args.estimation))[0]
            sim = simulate_material(physics, rec.t, rec.strain, rec.r, rec.mask)
            fits["R_sim"] = sim["fit_R"]
        else:
            sim = simulate_material(physics, t, strain_fraction(table, args.strain))
        columns = {
            "R_sim": sim["R_sim"],
            "dR_sim": sim["dR_sim"],
            "strain_sim": 100.0 * np.asarray(strain_fraction(table, args.strain)),
        }
        units = {"R_sim": "ohm", "dR_sim": "%", "strain_sim": "%"}
    else:
        from porosense.sim.calibrate import calibrated_load_column, simulate_record
        from porosense.sim.effects import measured_load

        physics = (physics or Physics()).without("baseline_drift")
        load = measured_load(effects)
        column = load[0] if load else (calibrated_load_column(args.params) if args.params else None)
        if column and not load and column not in table.columns:
            say(
                args,
                f"{args.replay} has no load column '{column}' (g) the parameters were calibrated with: replayed unloaded",
            )
            column = None
        rec = actuator_record(table, args.actuator, ts, column)
        sim = simulate_record(
            args.actuator,
            physics,
            rec,
            porosity=args.porosity,
            effects=effects or None,
            load_g=None if load else rec.load_g,
        )
        for c in range(rec.dr.shape[1]):
            for name, unit in (("R", "ohm"), ("dR", "%"), ("strain", "%")):
                columns[f"{name}_sim_{c}"], units[f"{name}_sim_{c}"] = sim[f"{name}_{c}"], unit
            fits[f"dR_sim_{c}"] = fit_percent(rec.dr[:, c], sim[f"dR_{c}"])
            if f"strain_{c}" in table.columns:
                fits[f"strain_sim_{c}"] = fit_percent(table[f"strain_{c}"], sim[f"strain_{c}"])
        for k in OUTPUTS[args.actuator]:
            if k not in columns.keys() - {f"strain_{c}" for c in range(3)} and k != "strain_0":
                columns[f"{k}_sim"] = sim[k]
                if k in table.columns:
                    fits[f"{k}_sim"] = fit_percent(table[k], sim[k])
    Recording(t, columns, {"replay": str(args.replay), "params": args.params}, units).to_csv(out)
    if not args.json:
        say(args, f"{out}  ({t.size} samples, {t[-1] - t[0] + ts:.1f} s)")
        for k, v in fits.items():
            say(args, f"fit of {k}: {v:.2f} %")
    emit_json({"path": str(out), "fits": fits}, args)
    return 0
