"""``porosense control``: closed-loop strain control on the board (tune, run)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from porosense.cli._args import (
    add_deprecated,
    add_legacy_positional,
    add_params_option,
    columns,
    load_params,
    take_positional,
)
from porosense.cli._data import add_data_options, add_json_options, blob_checked, emit_json, output_file, say
from porosense.errors import InputError

#: porosense.control.tuning.DEFAULT_TAU_CL_S (s), written out so that --help loads no solver;
#: tests/cli/test_startup_constants.py holds the two equal.
DEFAULT_TAU_CL_S = 0.5

TUNE_RULE_HELP = (
    "Rule: lambda (IMC) tuning of a PI on a first-order-plus-dead-time (FOPDT) model of commanded "
    "vacuum -> output, kp = T / (K (tau_cl + theta + Ts/2)), ki = kp / T, with K (output units per kPa), "
    "T (s) and theta (s) fitted to the recordings by output-error least squares."
)


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "control",
        help="closed-loop strain control on the board: tune PI gains, run targets",
        description=(
            "The board holds the strain you ask for: its controller (a PI per channel with anti-windup and a "
            "target slew limit, running at the sample rate on the on-device estimate) commands the regulator's "
            "vacuum. 'tune' identifies the commanded-vacuum-to-strain dynamics from recordings and picks the "
            "gains; 'run' sends them with targets (a constant or a trajectory), streams and reports tracking "
            "error, settling time and overshoot. Each has --json."
        ),
        epilog=(
            "examples:\n"
            "  porosense control tune --data step_10.csv step_20.csv step_40.csv step_60.csv --model model.bin "
            "--out gains.json --json\n"
            "  porosense control run --port emulator --model model.bin --gains gains.json --target 15 --hold 10 "
            "--out ctl_run.csv --plot ctl_run.png"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    csub = p.add_subparsers(dest="control_command", metavar="{tune,run}")
    _register_tune(csub)
    _register_run(csub)
    p.set_defaults(func=_no_subcommand)
    return p


def _no_subcommand(args) -> int:
    raise InputError("give a subcommand: 'porosense control tune' or 'porosense control run' (see --help)")


# ------------------------------------------------------------------------------------- tune


def _register_tune(csub) -> None:
    t = csub.add_parser(
        "tune",
        help="identify the vacuum-to-strain plant from recordings and pick PI gains",
        description=(
            "Identify the commanded-vacuum-to-output dynamics from recordings (the paper's steps and "
            "staircase as 'porosense simulate' or 'porosense demo' write them, or your own CSV/.mat with the "
            "command and the output), pick PI gains, predict the closed-loop step response (python-control) "
            "and print its settling time (2 % band) and overshoot; write the gains, the plant model and the "
            "rule to JSON. " + TUNE_RULE_HELP.replace("%", "%") + " The closed-loop time constant --tau-cl is "
            "the one knob: larger is slower and more robust. Gains are in kPa of vacuum per output unit (the "
            "model's output unit, % strain for the contractor): the output used here must be in the unit of "
            "the estimate the board controls."
        ),
        epilog="example: porosense control tune --data step_10.csv step_20.csv step_40.csv step_60.csv "
        "--model model.bin --out gains.json --tau-cl 0.5 --plot step.png",
    )
    t.add_argument("--data", nargs="+", metavar="FILE", help="recordings (CSV or .mat) with the command and the output")
    add_legacy_positional(t, "data", nargs="*")
    t.add_argument(
        "--input",
        nargs="+",
        default=["p_cmd_0"],
        metavar="COL",
        help="commanded regulator pressure column, kPa gauge (vacuum negative; default p_cmd_0)",
    )
    add_deprecated(t, "--command", "--input", "input", nargs="+")
    t.add_argument(
        "--output",
        nargs="+",
        default=None,
        metavar="COL",
        help="output column (default: strain_0, else the on-device estimate est_strain_0)",
    )
    t.add_argument(
        "--tau-cl",
        type=float,
        default=DEFAULT_TAU_CL_S,
        metavar="SECONDS",
        help=f"desired closed-loop time constant, s (default {DEFAULT_TAU_CL_S:g}: about the contractor's "
        "open-loop time constant, and within the board's fixed-point integral gain range)",
    )
    t.add_argument(
        "--slew",
        type=float,
        default=20.0,
        metavar="UNITS_PER_S",
        help="target slew limit, output units per s (default 20)",
    )
    t.add_argument(
        "--step",
        type=float,
        default=None,
        metavar="UNITS",
        help="size of the predicted step, output units (default: half the recordings' output span)",
    )
    t.add_argument(
        "--model",
        metavar="MODEL.bin",
        help="the model blob the board will run: tau_cl is raised, if needed, to the smallest whose gains "
        "the board's fixed point holds for this model and rate (the integral gain is 16-bit)",
    )
    t.add_argument("--out", default="gains.json", metavar="FILE.json", help="gains file (default gains.json)")
    t.add_argument("--force", action="store_true", help="replace an existing --out")
    t.add_argument("--plot", metavar="FILE.png", help="figure of the predicted closed-loop step")
    add_data_options(t)
    add_json_options(t, "the plant, the gains and the prediction")
    t.set_defaults(func=run_tune)


def _tune_columns(tables, args) -> tuple[str, str]:
    from porosense.cli._data import require_columns

    for tb in tables:
        require_columns(tb, [args.command])
    output = args.output[0] if args.output else None
    if output is None:
        for name in ("strain_0", "est_strain_0"):
            if all(name in tb for tb in tables):
                output = name
                break
        else:
            raise InputError(
                f"{tables[0].path}: no output column strain_0 or est_strain_0; name it with --output "
                f"(columns: {', '.join(tables[0].names)})"
            )
    for tb in tables:
        require_columns(tb, [output])
    return args.command, output


def _one_column(args, option: str) -> str | None:
    value = getattr(args, option)
    if value is None:
        return None
    cols = columns(value, option, args)
    if len(cols) != 1:
        raise InputError(f"--{option} {' '.join(cols)}: control tune takes one {option} column")
    return cols[0]


def run_tune(args) -> int:
    import numpy as np

    from porosense.cli._data import read_tables, sample_period
    from porosense.control import fit_fopdt, lambda_pi, predict_step, save_gains
    from porosense.control.tuning import RULE

    take_positional(args, "data", "--data")
    args.command = _one_column(args, "input")
    args.output = [_one_column(args, "output")] if args.output else None
    if not (math.isfinite(args.tau_cl) and args.tau_cl > 0):
        raise InputError(f"--tau-cl {args.tau_cl} must be a positive number of seconds")
    if not (math.isfinite(args.slew) and args.slew > 0):
        raise InputError(f"--slew {args.slew} must be a positive number of output units per second")
    out_path = output_file(args.out, "--out", force=args.force)
    plot = output_file(args.plot, "--plot") if args.plot else None
    for f in args.data:
        if not Path(f).is_file():
            raise InputError(f"recording {f} not found")
    tables = read_tables(args.data, args)
    ts = sample_period(tables, args)
    cmd, output = _tune_columns(tables, args)
    for tb in tables:
        tb.require_finite([cmd, output])
    from porosense.data.units import column_unit, normal_unit

    unit = column_unit(cmd, *(getattr(tb, "units", None) or {} for tb in tables))
    if unit is not None and normal_unit(unit) != "kPa":
        raise InputError(
            f"column {cmd} is in {unit}, not kPa: --input names the commanded regulator pressure "
            "(kPa gauge, vacuum negative; p_cmd_0 in porosense's recordings)"
        )
    vac = [-np.asarray(tb[cmd], dtype=float) for tb in tables]
    ys = [np.asarray(tb[output], dtype=float) for tb in tables]
    if any(np.any(v < -1e-9) for v in vac):
        raise InputError(f"column {cmd} holds positive pressures: the command is gauge vacuum, negative kPa")
    plant = fit_fopdt(vac, ys, ts, output_unit="%" if "strain" in output else "")
    tau_cl = float(args.tau_cl)
    if args.model:
        from porosense.control.tuning import board_tau_cl

        if not Path(args.model).is_file():
            raise InputError(f"model blob {args.model} not found")
        blob = blob_checked(args.model, Path(args.model).read_bytes())
        fitted = board_tau_cl(plant, tau_cl, args.slew, float(blob.out_scale[0]), blob.rate_hz)
        if fitted > tau_cl:
            say(
                args,
                f"tau_cl raised from {tau_cl:g} to {fitted:.3g} s: the board's fixed point holds no larger "
                f"integral gain for {args.model} at {blob.rate_hz:g} Hz",
            )
        tau_cl = fitted
    gains = lambda_pi(plant, tau_cl, args.slew)
    span = max(float(np.ptp(np.concatenate(ys))), 1e-9)
    step = float(args.step) if args.step is not None else round(span / 2.0, 1) or span / 2.0
    pred = predict_step(plant, gains, step)
    predicted = {**pred.summary(), "note": "linear loop around the FOPDT, target slew-limited"}
    doc = save_gains(
        out_path, gains, plant=plant, rule=RULE, tau_cl_s=tau_cl, output=output, predicted=predicted, sources=args.data
    )
    if plot:
        pred.plot(plot, title=f"predicted step of {step:g} ({output}), tau_cl {tau_cl:g} s")
    say(args, f"plant ({cmd} -> {output}, {len(tables)} recordings, Ts {ts:g} s): {plant}")
    say(
        args,
        f"gains (tau_cl {tau_cl:.3g} s): kp {gains.kp_kpa:.4g} kPa per unit, ki {gains.ki_kpa_per_s:.4g} "
        f"kPa per unit s, slew {gains.slew_per_s:g} units/s",
    )
    settle = "does not settle" if math.isnan(pred.settling_s) else f"settles in {pred.settling_s:.2f} s"
    say(
        args,
        f"predicted step of {step:g}: {settle} (2 % band), overshoot {pred.overshoot_pct:.1f} %, "
        f"peak vacuum {pred.peak_vacuum_kpa:.1f} kPa",
    )
    say(args, f"wrote {out_path}" + (f" and {plot}" if plot else ""))
    emit_json({**doc, "gains_file": str(out_path), "plot": str(plot) if plot else None}, args)
    return 0


# -------------------------------------------------------------------------------------- run


def _register_run(csub) -> None:
    r = csub.add_parser(
        "run",
        help="run a constant target or a trajectory on the board's controller and measure the tracking",
        description=(
            "Send the gains (--gains, from 'control tune'; else the board's stored gains), then a constant "
            "target (--target, held --hold s) or a trajectory (--trajectory FILE.csv with columns t_s,target "
            "or t_s,target0..target2, piecewise linear), stream the target, the on-device estimate, the "
            "vacuum command and, where the back-end knows it, the true output; vent at the end. Reports the "
            "tracking error (RMS and peak, in output units and % of the largest target) against the truth "
            "(else the estimate), and for a constant target the settling time (2 % band) and the overshoot. "
            "--port emulator[:ACTUATOR] and simboard[:ACTUATOR] start a simulated board here (with the true "
            "strain; --load-g sets its hanging load); any other value is a serial URL."
        ),
        epilog="example: porosense control run --port emulator --model model.bin --gains gains.json --target 15 "
        "--hold 10 --out ctl_run.csv --plot ctl_run.png",
    )
    r.add_argument(
        "--port",
        required=True,
        metavar="URL|emulator|simboard",
        help="serial port or pyserial URL, or emulator[:ACTUATOR] / simboard[:ACTUATOR]",
    )
    r.add_argument("--target", type=float, help="constant target, output units (e.g. 15 for 15 %% strain)")
    r.add_argument("--hold", type=float, default=10.0, metavar="SECONDS", help="how long to hold it, s (default 10)")
    r.add_argument("--trajectory", metavar="FILE.csv", help="targets over time: t_s,target (or target0..2)")
    r.add_argument("--gains", metavar="FILE.json", help="gains file from 'porosense control tune'")
    r.add_argument("--model", metavar="MODEL.bin", help="flash this model first (the board's rate is set to it)")
    r.add_argument(
        "--load-g",
        type=float,
        default=0.0,
        metavar="GRAMS",
        help="hanging load of a simulated board, g (0..500; default 0)",
    )
    add_deprecated(r, "--load", "--load-g", "load_g", type=float)
    r.add_argument("--seed", type=int, default=0, help="seed of a simulated board (default 0)")
    add_params_option(r)
    r.add_argument(
        "--out",
        metavar="FILE.csv",
        help="write the run (target, estimate, truth, command) as CSV; written sample by sample while the run "
        "goes on (flushed every second), then replaced by the whole recording",
    )
    r.add_argument("--force", action="store_true", help="replace an existing --out")
    r.add_argument("--plot", metavar="FILE.png", help="figure: target, estimate and true output against time")
    add_json_options(r, "the run's metrics")
    r.set_defaults(func=run_run)


def read_trajectory(path) -> tuple:
    """(t_s (n,), targets (n,) or (n, k)) from a trajectory CSV; InputError when malformed."""
    import numpy as np

    from porosense.data import load_data

    if not Path(path).is_file():
        raise InputError(f"trajectory {path} not found")
    tb = load_data(path, check=False)  # way points, not a sampled record
    if "t_s" not in tb:
        raise InputError(f"{path}: no column t_s (columns: {', '.join(tb.names)}; read as {tb.dialect})")
    if "target" in tb:
        names = ["target"]
    else:
        names = [f"target{i}" for i in range(3) if f"target{i}" in tb]
    if not names:
        raise InputError(f"{path}: no column target or target0..target2 (columns: {', '.join(tb.names)})")
    tb.require_finite(["t_s", *names])
    t = np.asarray(tb["t_s"], dtype=float)
    if len(t) < 2 or abs(t[0]) > 1e-9 or np.any(np.diff(t) <= 0):
        raise InputError(f"{path}: t_s must start at 0 and increase, with at least two rows")
    y = np.column_stack([np.asarray(tb[n], dtype=float) for n in names])
    return t, (y[:, 0] if y.shape[1] == 1 else y)


def run_run(args) -> int:
    from porosense.control.runner import RunRequest, execute_run

    if (args.target is None) == (args.trajectory is None):
        raise InputError("give either --target VALUE (with --hold) or --trajectory FILE.csv")
    if not (math.isfinite(args.hold) and args.hold > 0):
        raise InputError(f"--hold {args.hold} must be a positive number of seconds")
    if args.target is not None and not math.isfinite(args.target):
        raise InputError(f"--target {args.target} is not a number")
    if not 0.0 <= args.load_g <= 500.0:
        raise InputError(f"--load-g {args.load_g:g} g outside 0..500")
    out = output_file(args.out, "--out", force=args.force) if args.out else None
    plot = output_file(args.plot, "--plot") if args.plot else None
    trajectory = read_trajectory(args.trajectory) if args.trajectory else None
    gains = None
    if args.gains:
        from porosense.control import load_gains

        gains, _ = load_gains(args.gains)
    model = None
    if args.model:
        if not Path(args.model).is_file():
            raise InputError(f"model blob {args.model} not found")
        model = Path(args.model).read_bytes()

        blob_checked(args.model, model)  # refuse a model the board would refuse before opening the port
    req = RunRequest(
        port=args.port,
        target=args.target,
        hold_s=args.hold,
        trajectory=trajectory,
        gains=gains,
        model=model,
        load_g=args.load_g,
        seed=args.seed,
        log_path=str(out) if out else None,
        physics=load_params(args),
    )
    result = execute_run(req, log=lambda text: say(args, text))
    if out:
        # The whole recording replaces the log in one rename: a kill now keeps one or the other.
        tmp = out.with_name(out.stem + ".whole" + out.suffix)
        result.recording.to_csv(tmp)
        os.replace(tmp.with_suffix(".json"), out.with_suffix(".json"))
        os.replace(tmp, out)
    if plot:
        result.plot(plot)
    for line in result.summary_lines():
        say(args, line)
    emit_json({**result.to_dict(), "out": str(out) if out else None, "plot": str(plot) if plot else None}, args)
    return 0
