"""The main job: from nothing to an actuator that knows its own strain.

For one actuator, on a board (the emulator by default, the simboard, or a real board's URL):

1. run the paper's identification protocol on the board (vacuum steps at -10, -20, -40 and
   -60 kPa in duplicate and the staircase; the 3-DoF patterns for the segment) and record;
2. identify all four structures with the order search and the paper's split (estimation:
   staircase, -10, -60 kPa; validation: -20, -40 kPa), selected by mean fit;
3. print the paper-style table (fit % and RMS % per structure and recording, best marked);
4. quantize the selected model, flash it, verify it by replay against the bit-exact reference;
5. stream a fresh validation experiment with on-device estimates and report their fit live;
6. write a report folder (figures, summary.md, summary.html).
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from porosense.errors import DeviceError, InputError

ACTUATORS = ("bending", "contractor", "3dof")

#: Inputs and outputs per actuator (docs/conventions.md).
SIGNALS = {
    "contractor": (["dR_0"], ["strain_0"], ["strain (%)"]),
    "bending": (["dR_0"], ["curvature"], ["curvature (1/m)"]),
    "3dof": (["dR_0", "dR_1", "dR_2"], ["theta_x", "theta_y", "dz"], ["theta_x (deg)", "theta_y (deg)", "dz (mm)"]),
}

#: The paper's split: (estimation experiments, validation experiments); each run twice.
PROTOCOL = {
    "contractor": (["staircase", "step_10", "step_60"], ["step_20", "step_40"]),
    "bending": (["staircase", "step_10", "step_60"], ["step_20", "step_40"]),
    "3dof": (["sequential_10", "sequential_60", "two_level"], ["sequential_20", "sequential_40"]),
}
#: Experiments the paper ran once (the rest in duplicate).
SINGLE = {"staircase", "two_level"}

#: Device time runs this many times faster than wall time on the emulator.
EMULATOR_SPEED = 10.0


@dataclass
class DemoResult:
    """Everything one actuator's demo produced; figures in %, seconds."""

    actuator: str
    board: str
    recordings: dict
    table: str
    selected: dict
    ranking: dict
    quant: dict
    verify: dict
    on_device_fit: list
    float_fit: list
    report_dir: Path | None = None
    seconds: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"actuator": self.actuator, "board": self.board, "recordings": list(self.recordings),
                "table": self.table, "selected": self.selected, "ranking": self.ranking, "quant": self.quant,
                "verify": self.verify, "on_device_fit": self.on_device_fit, "float_fit": self.float_fit,
                "report_dir": str(self.report_dir) if self.report_dir else None, "seconds": self.seconds}


# ------------------------------------------------------------------------------ boards


@contextlib.contextmanager
def open_board(board: str, actuator: str, *, seed: int = 0):
    """Yield (Device, truth function or None) for ``board``: emulator, simboard or a URL."""
    from porosense.device import Device

    if board == "emulator":
        from porosense.emulator import Emulator

        # A busy host computer delays samples but never skips them: the recordings stay regular.
        with Emulator(actuator, realtime=True, speed=EMULATOR_SPEED, seed=seed, truth_log=True,
                      max_catch_up_s=3600.0) as emu:
            with Device.open(emu.url) as dev:
                yield dev, emu.truth
    elif board == "simboard":
        from porosense.simboard import DEFAULT_ELF, SimBoard

        with SimBoard(DEFAULT_ELF, actuator=actuator, seed=seed) as sb:
            with Device.open(sb.url, timeout_scale=4.0) as dev:
                yield dev, _simboard_truth(sb)
    else:
        with Device.open(board) as dev:
            yield dev, None


def _simboard_truth(sb):
    def truth(t_us: np.ndarray) -> dict:
        cols = sb.truth_columns()
        t = cols.pop("t")
        # The firmware's microsecond clock counts AVR time since reset.
        return {k: np.interp(t_us * 1e-6, t, v) for k, v in cols.items() if v.dtype.kind == "f"}

    return truth


# ------------------------------------------------------------------------------ steps


def record_protocol(dev, actuator: str, truth, *, rate_hz: int, progress: bool, log) -> dict:
    """Run the paper's protocol on ``dev``; returns {name: Recording} in protocol order."""
    from porosense.experiment import run_schedule
    from porosense.sim import schedule

    est, val = PROTOCOL[actuator]
    n_ch = len(SIGNALS[actuator][0])
    recs = {}
    for exp in est + val:
        for copy in ("a",) if exp in SINGLE else ("a", "b"):
            name = exp if exp in SINGLE else f"{exp}_{copy}"
            recs[name] = run_schedule(dev, schedule(exp), rate_hz=rate_hz, n_channels=n_ch, truth=truth,
                                      progress=progress, meta={"actuator": actuator, "experiment": exp, "copy": copy})
            lost = recs[name].meta["samples_lost"]
            log(f"  recorded {name}: {len(recs[name])} samples" + (f", {lost} lost" if lost else ""))
    return recs


def _io(recs: dict, actuator: str, names: list[str], j: int):
    inputs, outputs, _ = SIGNALS[actuator]
    u = [np.column_stack([recs[n][c] / 100.0 for c in inputs]) for n in names]
    y = [recs[n][outputs[j]] for n in names]
    return u, y


def paper_table(searches: list, est_names: list[str], val_names: list[str], output_names: list[str]) -> str:
    """Fit % / RMS % per structure (best of its order search) and recording; '*' marks the best."""
    lines = []
    names = est_names + val_names
    for out, res in zip(output_names, searches):
        per = res.best_per_structure()
        best = res.best.structure
        head = f"{out:<14}" + "".join(f"{n[:11]:>12}" for n in names) + f"{'mean':>12}"
        lines += [head, "-" * len(head)]
        for s in ("linear", "hammerstein", "wiener", "wh"):
            if s not in per:
                continue
            c = per[s]
            fits = c.fit_estimation + c.fit_validation
            rms = c.rms_estimation + c.rms_validation
            mark = "*" if s == best else " "
            label = f"{mark}{s} ({c.n_poles}p{c.n_zeros}z)"
            lines.append(f"{label:<14}" + "".join(f"{f:>6.1f}/{r:<5.1f}" for f, r in zip(fits, rms))
                         + f"{c.mean_fit:>6.1f}/{c.mean_rms:<5.1f}")
        lines.append(f"  columns: fit % / RMS %; estimation: {', '.join(est_names)}; "
                     f"validation: {', '.join(val_names)}; * selected by mean fit")
        lines.append("")
    return "\n".join(lines)


def run_demo(actuator: str = "contractor", board: str = "emulator", *, out_dir="out/demo", rate_hz: int = 50,
             max_poles: int = 3, seed: int = 0, progress: bool = True, log=print) -> DemoResult:
    """Run the whole pipeline for one actuator; see the module docstring. ``max_poles`` bounds
    the order search (the paper's grid is 10; 3 keeps the demo within minutes)."""
    from porosense.ident import fit_percent, search
    from porosense.quant import FixedPointEstimator, quantize
    from porosense.structure import EstimatorStructure

    if actuator not in ACTUATORS:
        raise InputError(f"unknown actuator {actuator!r}; choose one of {', '.join(ACTUATORS)}")
    out = Path(out_dir) / actuator
    out.mkdir(parents=True, exist_ok=True)
    inputs, outputs, labels = SIGNALS[actuator]
    est_exps, val_exps = PROTOCOL[actuator]
    clock = {}
    t0 = time.perf_counter()
    log(f"[{actuator}] board: {board}")
    with open_board(board, actuator, seed=seed) as (dev, truth):
        hello = dev.hello()
        log(f"  {hello}")
        dev.calibrate_r0(n_samples=32, channels=(1 << len(inputs)) - 1)
        recs = record_protocol(dev, actuator, truth, rate_hz=rate_hz, progress=progress, log=log)
        (out / "recordings").mkdir(exist_ok=True)
        for name, rec in recs.items():
            rec.to_csv(out / "recordings" / f"{name}.csv")
        clock["record"] = time.perf_counter() - t0
        if truth is None:
            log(f"  a real board gives no ground truth: recordings are in {out / 'recordings'}; add the measured "
                f"{', '.join(outputs)} columns and run 'porosense identify'")
            return DemoResult(actuator, board, recs, "", {}, {}, {}, {}, [], [], None, clock)

        est_names = [n for n in recs if n.rsplit("_", 1)[0] in est_exps or n in est_exps]
        val_names = [n for n in recs if n not in est_names]
        searches = []
        t1 = time.perf_counter()
        # The outputs share the EEPROM's model region: each output's chain gets an equal share,
        # counted with wide (20-byte) sections so the quantized blob always fits.
        from functools import partial

        from porosense.quant.blob import MAX_BLOB_LEN
        from porosense.quant.design import blob_size

        share = (MAX_BLOB_LEN - 26) // len(outputs) + 26
        size_fn = partial(blob_size, section_bytes=20.0, compact=len(outputs) > 1)
        for j, name in enumerate(outputs):
            u, y = _io(recs, actuator, est_names, j)
            vu, vy = _io(recs, actuator, val_names, j)
            log(f"  identifying {name}: 4 structures, poles 1..{max_poles}, zeros < poles, 2 starts")
            searches.append(search(u=u, y=y, ts=1.0 / rate_hz, validation=(vu, vy), poles=range(1, max_poles + 1),
                                   inputs=inputs, output=name, progress=progress, size_fn=size_fn,
                                   max_bytes=share, input_unit="dR/100",  # _io divides dR (%) by 100
                                   output_unit=getattr(recs[est_names[0]], "units", {}).get(name)))
        clock["identify"] = time.perf_counter() - t1
        table = paper_table(searches, est_names, val_names, outputs)
        log("")
        log(table)

        # One MISO chain per output in a single on-device structure.
        chains = [s.model.to_structure() for s in searches]
        structure = EstimatorStructure(tuple(inputs), tuple(o for c in chains for o in c.outputs), 1.0 / rate_hz,
                                       meta={"actuator": actuator}, input_units=("dR/100",) * len(inputs))
        qrecs = [(n, np.column_stack([recs[n][c] / 100.0 for c in inputs]),
                  np.column_stack([recs[n][o] for o in outputs])) for n in val_names]
        q = quantize(structure, recordings=qrecs)
        blob = q.blob
        loss = q.report.worst_loss_points
        log(f"  quantized: {blob.length} bytes, worst fixed-point fit loss "
            f"{loss if loss is not None else float('nan'):.3f} points, {q.report.saturated_samples} saturated samples")
        from porosense.ident import save_models

        save_models([r.model for r in searches], out / "model.json")
        (out / "model.bin").write_bytes(blob.to_bytes())
        info = dev.write_model(blob.to_bytes())
        log(f"  flashed: {info}")

        # Verify: replay a validation recording through the device and the bit-exact reference.
        vrec = recs[val_names[0]]
        dr_centi = np.zeros((len(vrec), 3), dtype=np.int16)
        for i, c in enumerate(inputs):
            dr_centi[:, i] = np.round(vrec[c] * 100).astype(np.int16)
        n_replay = min(len(vrec), 1000)
        on_dev = dev.replay(dr_centi[:n_replay])
        ref, _ = FixedPointEstimator(blob).run(dr_centi[:n_replay])
        mismatches = int(np.count_nonzero(np.asarray(on_dev) != ref))
        verify = {"samples": n_replay, "mismatches": mismatches, "bit_exact": mismatches == 0}
        log(f"  verified by replay: {n_replay} samples, {mismatches} mismatches")
        if mismatches:
            raise DeviceError(f"device estimates differ from the reference in {mismatches} of {n_replay} samples")

        # Stream a fresh validation experiment with on-device estimates; fit shown live.
        t2 = time.perf_counter()
        from porosense.experiment import run_schedule
        from porosense.sim import schedule

        live_exp = val_exps[0]
        live = run_schedule(dev, schedule(live_exp), rate_hz=rate_hz, n_channels=len(inputs), truth=truth,
                            progress=progress, out_scale=blob.out_scale, output_names=outputs,
                            monitor=_live_fit(outputs), meta={"actuator": actuator, "experiment": live_exp})
        clock["stream"] = time.perf_counter() - t2
        live.to_csv(out / "recordings" / f"live_{live_exp}.csv")
    on_device = [fit_percent(live[o], live[f"est_{o}"]) for o in outputs]
    u_live = np.column_stack([live[c] / 100.0 for c in inputs])
    y_float = structure.simulate(u_live)
    float_fit = [fit_percent(live[o], y_float[:, j]) for j, o in enumerate(outputs)]
    for o, a, b in zip(outputs, on_device, float_fit):
        log(f"  live {live_exp}: on-device fit of {o} {a:.2f} %, host float model {b:.2f} % "
            f"(difference {a - b:+.2f} points)")

    ranking = {o: {s: c.mean_fit for s, c in res.best_per_structure().items()} for o, res in zip(outputs, searches)}
    selected = {o: {"structure": r.best.structure, "poles": r.best.n_poles, "zeros": r.best.n_zeros,
                    "mean_fit": r.best.mean_fit, "mean_rms": r.best.mean_rms} for o, r in zip(outputs, searches)}
    result = DemoResult(actuator, board, recs, table, selected, ranking,
                        {"bytes": blob.length, "report": q.report.to_dict()}, verify, on_device, float_fit,
                        None, clock)
    from porosense.report.demo_report import write_demo_report

    t3 = time.perf_counter()
    result.report_dir = write_demo_report(result, searches, live, structure, out, inputs, outputs, labels)
    clock["report"] = time.perf_counter() - t3
    clock["total"] = time.perf_counter() - t0
    log(f"  report: {result.report_dir / 'summary.html'} ({clock['total']:.0f} s in all)")
    return result


def _live_fit(outputs):
    """Running fit (%) of the on-device estimates against the truth, for the progress bar."""
    from porosense.ident import fit_percent

    def monitor(rows: dict) -> str:
        parts = []
        for o in outputs:
            y, e = rows.get(o), rows.get(f"est_{o}")
            if y is None or len(y) < 50 or np.ptp(y) == 0:
                return ""
            parts.append(f"{o} fit {fit_percent(y, e):.1f}%")
        return ", ".join(parts)

    return monitor
