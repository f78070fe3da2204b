"""``porosense simulate``: run the paper's experiments on a simulated actuator, write recordings."""

from __future__ import annotations

import argparse

from porosense.cli._args import ACTUATORS, add_deprecated
from porosense.cli._data import add_json_options, emit_json


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "simulate",
        help="simulate the paper's experiments and write recordings (CSV + JSON, or .mat)",
        description=(
            "Simulate an actuator (contractor: axial strain %; bending: curvature 1/m; 3dof: "
            "theta_x, theta_y in deg and dz in mm) through one of the paper's experiment "
            "schedules and write each recording as CSV with a JSON sidecar (and/or MATLAB "
            ".mat), each file whole as soon as its recording is simulated (a stopped or killed run "
            "keeps every recording finished before it); recordings already in the folder are kept "
            "unless --force. Pressures in kPa (gauge, vacuum < 0), dR in %, porosity in %, load in g, "
            "rate in Hz. --experiment paper runs the paper's set: for contractor and bending "
            "the steps at -10, -20, -40, -60 kPa in duplicate and the staircase; for the 3dof "
            "segment the sequential patterns at the four levels and the two-level pattern. "
            "Extra effects (off by default) are added with --effect NAME or NAME:param=value."
        ),
        epilog=(
            "example: porosense simulate contractor --experiment step_60 --porosity 86 "
            "--load-g 500 --rate 50 --seed 1 --out runs/"
        ),
    )
    p.add_argument(
        "actuator", choices=(*ACTUATORS, "material"), help="which actuator to simulate (material: with --replay)"
    )
    p.add_argument(
        "--experiment",
        "-e",
        action="append",
        help="schedule name (step_10..step_60, staircase, sequential_L, parallel_L, "
        "two_level) or 'paper'; repeat for several",
    )
    p.add_argument(
        "--porosity",
        type=float,
        default=None,
        help="porosity in %% (60-90; default 82 contractor, 84 bending, 76 3dof)",
    )
    p.add_argument("--load-g", type=float, default=0.0, metavar="GRAMS", help="hanging load in g (0-500, default 0)")
    add_deprecated(p, "--load", "--load-g", "load_g", type=float)
    p.add_argument("--rate", type=float, default=50.0, metavar="HZ", help="sample rate in Hz (default 50)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument(
        "--repeats", type=int, default=1, help="recordings per experiment with seeds seed, seed+1, ... (default 1)"
    )
    p.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="NAME[:k=v,...]",
        help="switch on a named effect (drift, time_delay, periodic_disturbance, "
        "saturation, load_dependence, slow_relaxation, cross_coupling, outliers)",
    )
    p.add_argument(
        "--format", choices=("csv", "mat", "both"), default="csv", help="file format (default csv with a JSON sidecar)"
    )
    p.add_argument("--no-noise", action="store_true", help="noiseless sensors (for checks)")
    p.add_argument(
        "--params", metavar="PARAMS.json", help="simulator parameters (porosense calibrate; default: the built-in ones)"
    )
    p.add_argument(
        "--replay",
        metavar="REC",
        help="replay this recording's inputs (p_cmd_C, and its load_g column in g when --params is extended by "
        "load_dependence or was calibrated with that load column; material: --strain) through the simulator, "
        "noiseless, "
        "and write t with R_sim, dR_sim, strain_sim (and the outputs, _sim) to --out FILE.csv, printing their fit "
        "against the recording's own columns",
    )
    p.add_argument("--strain", metavar="COL", help="material --replay: the strain column (%% unless stated as 1)")
    p.add_argument(
        "--resistance",
        metavar="COL",
        help="material --replay: the measured resistance (ohm); R0 and its drift come from it (on --estimation)",
    )
    p.add_argument("--estimation", metavar="A:B", help="material --replay: samples R0 and drift are taken from")
    p.add_argument(
        "--out",
        default=None,
        help="output directory (created if needed; default recordings/); with --replay the CSV file "
        "(default REC's name with _sim)",
    )
    p.add_argument("--force", action="store_true", help="replace recordings already at --out")
    add_json_options(p, "the files written")
    p.set_defaults(func=run)
    return p


def parse_effects(specs) -> dict:
    """``["drift", "time_delay:delay_s=0.3"]`` -> ``{"drift": {}, "time_delay": {"delay_s": 0.3}}``."""
    from porosense.errors import InputError

    effects = {}
    for spec in specs:
        name, _, params = spec.partition(":")
        values = {}
        for item in filter(None, params.split(",")):
            key, eq, value = item.partition("=")
            try:
                if not eq:
                    raise ValueError
                values[key.strip()] = float(value)
            except ValueError:
                raise InputError(f"--effect {spec}: expected NAME:param=number,...") from None
        effects[name.strip()] = values
    return effects


def paper_experiments(actuator: str, repeats: int) -> list[tuple[str, int]]:
    """(experiment, repeat index) pairs of the paper's set for ``actuator``."""
    if actuator == "3dof":
        return [(f"sequential_{lv}", 0) for lv in (10, 20, 40, 60)] + [("two_level", 0)]
    steps = [(f"step_{lv}", k) for lv in (10, 20, 40, 60) for k in range(max(repeats, 2))]
    return steps + [("staircase", 0)]


def recording_stem(actuator: str, experiment: str, porosity: float, load_g: float, seed: int) -> str:
    """File name (without suffix) of one simulated recording: porosity in %, load in g."""
    return f"{actuator}_{experiment}_p{porosity:g}_l{load_g:g}_s{seed}"


def _refuse_to_replace(out, stems, fmt: str) -> None:
    """InputError naming a recording (CSV, its JSON sidecar or .mat) that the run would replace."""
    from porosense.errors import InputError

    suffixes = {"csv": (".csv", ".json"), "mat": (".mat",), "both": (".csv", ".json", ".mat")}[fmt]
    there = [out / f"{stem}{sfx}" for stem in dict.fromkeys(stems) for sfx in suffixes]
    there = [path for path in there if path.exists()]
    if there:
        more = f" (and {len(there) - 1} more)" if len(there) > 1 else ""
        raise InputError(f"{there[0]} exists{more}: --force replaces it")


MIN_RATE_HZ, MAX_RATE_HZ = 1.0, 10_000.0  # the physics steps at 1 ms or finer; beyond, records get huge


def run(args) -> int:
    import math
    from pathlib import Path

    from porosense.errors import InputError
    from porosense.sim import resolve_effects, run_experiment

    physics, file_effects = None, {}
    if args.params:
        from porosense.sim.extend import load_params

        physics, file_effects = load_params(args.params)
    if args.replay:
        from porosense.cli.replay import replay

        return replay(args, physics, file_effects)
    if args.actuator == "material":
        raise InputError("simulate material replays a tensile recording: give --params PARAMS.json --replay REC")
    if not args.experiment:
        raise InputError("give --experiment NAME (or --replay REC)")
    if args.out is None:
        args.out = "recordings"
    if args.repeats < 1:
        raise InputError("--repeats must be at least 1")
    if not (math.isfinite(args.rate) and MIN_RATE_HZ <= args.rate <= MAX_RATE_HZ):
        raise InputError(f"--rate {args.rate:g}: the simulator samples at {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz")
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise InputError(f"--out {args.out} is a file, not a folder; give a folder for the recordings")
    effects = {**file_effects, **resolve_effects(parse_effects(args.effect))}
    jobs = []
    for name in args.experiment:
        if name == "paper":
            jobs += paper_experiments(args.actuator, args.repeats)
        else:
            jobs += [(name, k) for k in range(args.repeats)]
    out = Path(args.out)
    porosity = args.porosity
    if porosity is None:
        from porosense.sim import Physics
        from porosense.sim.plant import default_porosity

        porosity = default_porosity(args.actuator, physics or Physics())
    if not args.force:
        _refuse_to_replace(
            out,
            [recording_stem(args.actuator, name, porosity, args.load_g, args.seed + k) for name, k in jobs],
            args.format,
        )
    listing = []
    for name, k in jobs:
        seed = args.seed + k
        rec = run_experiment(
            args.actuator,
            name,
            porosity=args.porosity,
            load_g=args.load_g,
            rate_hz=args.rate,
            seed=seed,
            effects=effects,
            noise=not args.no_noise,
            physics=physics,
        )
        stem = recording_stem(args.actuator, name, rec.meta["porosity"], rec.meta["load_g"], seed)
        written = []
        if args.format in ("csv", "both"):
            written.append(rec.to_csv(out / f"{stem}.csv"))
        if args.format in ("mat", "both"):
            written.append(rec.to_mat(out / f"{stem}.mat"))
        for path in written:
            listing.append(
                {"path": str(path), "experiment": name, "seed": seed, "samples": len(rec), "duration_s": rec.duration}
            )
            if not args.json:
                print(f"{path}  ({len(rec)} samples, {rec.duration:.1f} s)")
    emit_json(listing, args)
    return 0
