"""The main job: from nothing to an actuator that knows its own strain.

For one actuator, on a board (the emulator by default, the simboard, or a real board's URL):

1. run the paper's identification protocol on the board (vacuum steps at -10, -20, -40 and
   -60 kPa in duplicate and the staircase; the 3-DoF patterns for the segment) and record;
2. identify all four structures with the order search and the paper's split (estimation:
   staircase, -10, -60 kPa; validation: -20, -40 kPa), selected by mean fit; the 3-DoF
   segment at the paper's orders instead (PAPER_ORDERS: WH, 2 poles and 1 zero, 10
   breakpoints, the model of the paper's 3-DoF table), WH kept;
3. print the paper-style table (fit % and RMS % per structure and recording, best marked);
4. quantize the selected model, store it (the EEPROM beside the running model when it fits
   there, else the flash model store by upload), verify it by replay against the bit-exact
   reference;
5. stream a fresh validation experiment with on-device estimates and report their fit live;
6. close the loop: tune PI gains from the recordings, run a few strain targets on the board's
   controller (single-channel actuators) and measure them against the truth;
7. write a report folder (figures, summary.md, summary.html).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from porosense.boards import SIM_WATCHDOG_MS, open_board
from porosense.errors import DeviceError, InputError, ModelError
from porosense.experiment import run_schedule
from porosense.firmware.flash_store import upload as flash_upload
from porosense.ident import fit_percent, search
from porosense.protocol.model_blob import MAX_BLOB_LEN
from porosense.protocol.model_layout import AREA_LEN, FLASH_BLOB_MAX
from porosense.quant import FixedPointEstimator, quantize
from porosense.quant.design import blob_size
from porosense.sim import ACTUATORS, schedule
from porosense.structure import EstimatorStructure
from porosense.workflows.demo_report import write_demo_report

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

#: Actuators identified at the paper's orders instead of an order search: (poles, zeros, breakpoints)
#: of every structure in the table; the WH model is the one flashed (the paper's 3-DoF table).
PAPER_ORDERS = {"3dof": (2, 1, 10)}


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
    control: dict | None = None

    def to_dict(self) -> dict:
        return {
            "actuator": self.actuator,
            "board": self.board,
            "recordings": list(self.recordings),
            "table": self.table,
            "selected": self.selected,
            "ranking": self.ranking,
            "quant": self.quant,
            "verify": self.verify,
            "on_device_fit": self.on_device_fit,
            "float_fit": self.float_fit,
            "report_dir": str(self.report_dir) if self.report_dir else None,
            "seconds": self.seconds,
            "control": self.control,
        }


# ------------------------------------------------------------------------------ steps


def record_protocol(dev, actuator: str, truth, *, rate_hz: int, progress: bool, log) -> dict:
    """Run the paper's identification protocol on a board.

    Parameters
    ----------
    dev : Device
        The board, R0 calibrated.
    actuator : str
        ``contractor``, ``bending`` or ``3dof`` (PROTOCOL names its experiments).
    truth : TruthSource or None
        True outputs by device time (a simulated board), else None.
    rate_hz : int
        Sample rate (Hz).
    progress : bool
        Show a progress bar per experiment.
    log : callable
        Receives one line per recording.

    Returns
    -------
    dict of str to Recording
        One recording per run, in protocol order (``step_10_a``, ``step_10_b``, ...).
    """
    est, val = PROTOCOL[actuator]
    n_ch = len(SIGNALS[actuator][0])
    recs = {}
    for exp in est + val:
        for copy in ("a",) if exp in SINGLE else ("a", "b"):
            name = exp if exp in SINGLE else f"{exp}_{copy}"
            recs[name] = run_schedule(
                dev,
                schedule(exp),
                rate_hz=rate_hz,
                n_channels=n_ch,
                truth=truth,
                progress=progress,
                meta={"actuator": actuator, "experiment": exp, "copy": copy},
            )
            lost = recs[name].meta["samples_lost"]
            log(f"  recorded {name}: {len(recs[name])} samples" + (f", {lost} lost" if lost else ""))
    return recs


def _io(recs: dict, actuator: str, names: list[str], j: int):
    inputs, outputs, _ = SIGNALS[actuator]
    u = [np.column_stack([recs[n][c] / 100.0 for c in inputs]) for n in names]
    y = [recs[n][outputs[j]] for n in names]
    return u, y


def paper_table(
    searches: list, est_names: list[str], val_names: list[str], output_names: list[str], chosen: list | None = None
) -> str:
    """The paper-style table: fit % / RMS % per structure (the best of its order search) and recording.

    Parameters
    ----------
    searches : list of SearchResult
        One order search per output.
    est_names, val_names : list of str
        Estimation and validation recordings, in the searches' order.
    output_names : list of str
        One name per output.
    chosen : list of Candidate, optional
        The candidate kept per output (default each search's best); marked with ``*``.

    Returns
    -------
    str
        The table as text, one block per output.
    """
    lines = []
    names = est_names + val_names
    for k, (out, res) in enumerate(zip(output_names, searches)):
        per = res.best_per_structure()
        best = (chosen[k] if chosen else res.best).structure
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
            lines.append(
                f"{label:<14}"
                + "".join(f"{f:>6.1f}/{r:<5.1f}" for f, r in zip(fits, rms))
                + f"{c.mean_fit:>6.1f}/{c.mean_rms:<5.1f}"
            )
        rule = "the paper's structure and orders" if chosen else "selected by mean fit"
        lines.append(
            f"  columns: fit % / RMS %; estimation: {', '.join(est_names)}; "
            f"validation: {', '.join(val_names)}; * {rule}"
        )
        lines.append("")
    return "\n".join(lines)


def run_demo(
    actuator: str = "contractor",
    board: str = "emulator",
    *,
    out_dir="out/demo",
    rate_hz: int = 50,
    max_poles: int = 3,
    seed: int = 0,
    progress: bool = True,
    log=print,
    physics=None,
) -> DemoResult:
    """Run the whole pipeline for one actuator (see the module docstring).

    Parameters
    ----------
    actuator : str
        ``contractor``, ``bending`` or ``3dof``.
    board : str
        ``emulator``, ``simboard`` or a serial URL (:func:`porosense.boards.open_board`); a real
        board gives no truth, so the demo records and stops.
    out_dir : str or Path
        Report folder; the actuator's results go to ``out_dir/actuator``.
    rate_hz : int
        Sample rate (Hz).
    max_poles : int
        Largest number of poles of the order search (the paper's grid is 10; 3 keeps the demo
        within minutes).
    seed : int
        Noise seed of a simulated actuator.
    progress : bool
        Show progress bars.
    log : callable
        Receives the demo's lines.
    physics : porosense.sim.Physics, optional
        Parameters of a simulated actuator (``porosense calibrate``; default the built-in ones).

    Returns
    -------
    DemoResult
        The recordings, the table, the selected models, the quantization, the verification,
        the on-device and float fits (%), the control segment and the time of each step (s).
    """
    if actuator not in ACTUATORS:
        raise InputError(f"unknown actuator {actuator!r}; choose one of {', '.join(ACTUATORS)}")
    out = Path(out_dir) / actuator
    out.mkdir(parents=True, exist_ok=True)
    inputs, outputs, labels = SIGNALS[actuator]
    est_exps, val_exps = PROTOCOL[actuator]
    clock = {}
    t0 = time.perf_counter()
    log(f"[{actuator}] board: {board}")
    with open_board(board, actuator=actuator, seed=seed, physics=physics) as opened:
        dev, truth, upload = opened.device, opened.truth, opened.upload
        hello = dev.hello()
        log(f"  {hello}")
        dev.calibrate_r0(n_samples=32, channels=(1 << len(inputs)) - 1)
        recs = record_protocol(dev, actuator, truth, rate_hz=rate_hz, progress=progress, log=log)
        (out / "recordings").mkdir(exist_ok=True)
        for name, rec in recs.items():
            rec.to_csv(out / "recordings" / f"{name}.csv")
        clock["record"] = time.perf_counter() - t0
        if truth is None:
            log(
                f"  a real board gives no ground truth: recordings are in {out / 'recordings'}; add the measured "
                f"{', '.join(outputs)} columns and run 'porosense identify'"
            )
            return DemoResult(actuator, board, recs, "", {}, {}, {}, {}, [], [], None, clock)

        est_names = [n for n in recs if n.rsplit("_", 1)[0] in est_exps or n in est_exps]
        val_names = [n for n in recs if n not in est_names]
        t1 = time.perf_counter()
        searches, chosen = identify_outputs(
            recs, actuator, est_names, val_names, rate_hz=rate_hz, max_poles=max_poles, progress=progress, log=log
        )
        clock["identify"] = time.perf_counter() - t1
        table = paper_table(searches, est_names, val_names, outputs, chosen if actuator in PAPER_ORDERS else None)
        log("")
        log(table)

        structure, q = quantize_model(chosen, recs, actuator, val_names, rate_hz)
        blob = q.blob
        loss = q.report.worst_loss_points
        log(
            f"  quantized: {blob.length} bytes, worst fixed-point fit loss "
            f"{loss if loss is not None else float('nan'):.3f} points, {q.report.saturated_samples} saturated samples"
        )
        from porosense.ident import save_models

        save_models([c.model for c in chosen], out / "model.json")
        (out / "model.bin").write_bytes(blob.to_bytes())
        watchdog = SIM_WATCHDOG_MS if opened.simulated else None
        info = store_model(dev, blob.to_bytes(), upload, watchdog_ms=watchdog, log=log)

        verify = verify_by_replay(dev, blob, recs[val_names[0]], inputs, log=log)
        verify["store"], verify["slot"] = info.store, info.slot

        # Stream a fresh validation experiment with on-device estimates; fit shown live.
        t2 = time.perf_counter()
        from porosense.experiment import run_schedule
        from porosense.sim import schedule

        live_exp = val_exps[0]
        live = run_schedule(
            dev,
            schedule(live_exp),
            rate_hz=rate_hz,
            n_channels=len(inputs),
            truth=truth,
            progress=progress,
            out_scale=blob.out_scale,
            output_names=outputs,
            monitor=_live_fit(outputs),
            meta={"actuator": actuator, "experiment": live_exp},
        )
        clock["stream"] = time.perf_counter() - t2
        live.to_csv(out / "recordings" / f"live_{live_exp}.csv")

        control_run = control = None
        if len(inputs) == 1:
            from porosense.workflows.control_segment import run_segment

            t4 = time.perf_counter()
            control, control_run = run_segment(dev, truth, recs, outputs[0], float(blob.out_scale[0]), rate_hz, log=log)
            control_run.to_csv(out / "recordings" / "closed_loop.csv")
            clock["control"] = time.perf_counter() - t4
    on_device = [fit_percent(live[o], live[f"est_{o}"]) for o in outputs]
    u_live = np.column_stack([live[c] / 100.0 for c in inputs])
    y_float = structure.simulate(u_live)
    float_fit = [fit_percent(live[o], y_float[:, j]) for j, o in enumerate(outputs)]
    for o, a, b in zip(outputs, on_device, float_fit):
        log(
            f"  live {live_exp}: on-device fit of {o} {a:.2f} %, host float model {b:.2f} % "
            f"(difference {a - b:+.2f} points)"
        )

    ranking = {o: {s: c.mean_fit for s, c in res.best_per_structure().items()} for o, res in zip(outputs, searches)}
    selected = {
        o: {
            "structure": c.structure,
            "poles": c.n_poles,
            "zeros": c.n_zeros,
            "mean_fit": c.mean_fit,
            "mean_rms": c.mean_rms,
            "rule": "paper orders" if actuator in PAPER_ORDERS else "order search, best mean fit",
        }
        for o, c in zip(outputs, chosen)
    }
    result = DemoResult(
        actuator,
        board,
        recs,
        table,
        selected,
        ranking,
        {"bytes": blob.length, "report": q.report.to_dict()},
        verify,
        on_device,
        float_fit,
        None,
        clock,
        control.to_dict() if control else None,
    )

    t3 = time.perf_counter()
    result.report_dir = write_demo_report(
        result, searches, live, structure, out, inputs, outputs, labels, control_run=control_run
    )
    clock["report"] = time.perf_counter() - t3
    clock["total"] = time.perf_counter() - t0
    log(f"  report: {result.report_dir / 'summary.html'} ({clock['total']:.0f} s in all)")
    return result


def identify_outputs(
    recs: dict,
    actuator: str,
    est_names: list[str],
    val_names: list[str],
    *,
    rate_hz: int,
    max_poles: int,
    progress: bool = False,
    log=print,
):
    """Identify every output of an actuator.

    The 3-DoF segment is fitted at the paper's orders (PAPER_ORDERS: every structure at 2 poles
    / 1 zero / 10 breakpoints for the table, WH kept); the others by the order search up to
    ``max_poles``, best mean fit kept, each output's chain sized to share the EEPROM's model area.

    Parameters
    ----------
    recs : dict of str to Recording
        The protocol's recordings.
    actuator : str
        Names the signals (SIGNALS) and the orders (PAPER_ORDERS).
    est_names, val_names : list of str
        Estimation and validation recordings.
    rate_hz : int
        Sample rate of the recordings (Hz).
    max_poles : int
        Largest number of poles of the order search.
    progress : bool
        Show the searches' progress.
    log : callable
        Receives one line per output.

    Returns
    -------
    searches : list of SearchResult
        One per output.
    chosen : list of Candidate
        The candidate kept per output.
    """
    inputs, outputs, _ = SIGNALS[actuator]
    paper = PAPER_ORDERS.get(actuator)
    if paper:
        poles, zeros, bps = paper
        log(
            f"  {actuator}: WH at the paper's orders ({poles} poles, {zeros} zero, {bps} breakpoints; the other "
            "structures at the same orders for the table), stored in the EEPROM when it fits beside the running "
            "model, else in the flash store"
        )
        grid = [(st, poles, zeros) for st in ("linear", "hammerstein", "wiener", "wh")]
        capacity = FLASH_BLOB_MAX
    else:
        grid, bps = None, 10
        capacity = MAX_BLOB_LEN
    # Each output's chain gets a share of the slot; the quantizer encodes the whole compactly
    # when it does not fit with full tables, so a share is sized with compact tables.
    compact = len(outputs) > 1
    share = (capacity - 26) // len(outputs) + 26
    size_fn = partial(blob_size, section_bytes=20.0, compact=compact)
    searches = []
    for j, name in enumerate(outputs):
        u, y = _io(recs, actuator, est_names, j)
        vu, vy = _io(recs, actuator, val_names, j)
        what = "4 structures at the paper's orders" if paper else f"4 structures, poles 1..{max_poles}, zeros < poles"
        log(f"  identifying {name}: {what}, 2 starts")
        searches.append(
            search(
                u=u,
                y=y,
                ts=1.0 / rate_hz,
                validation=(vu, vy),
                poles=range(1, max_poles + 1),
                criterion="paper",  # the paper's rule: the best mean fit over all recordings
                staged=False,
                grid=grid,
                n_breakpoints=bps,
                inputs=inputs,
                output=name,
                progress=progress,
                size_fn=size_fn,
                max_bytes=share,
                input_unit="dR/100",  # _io divides dR (%) by 100
                output_unit=getattr(recs[est_names[0]], "units", {}).get(name),
            )
        )
    chosen = [r.best_per_structure()["wh"] if paper else r.best for r in searches]
    return searches, chosen


def quantize_model(chosen: list, recs: dict, actuator: str, val_names: list[str], rate_hz: int):
    """Quantize the chosen models as one on-device structure (one MISO chain per output).

    Paper-order sets are quantized for a flash store slot (full tables when they fit 1,016
    bytes), the others for the EEPROM.

    Parameters
    ----------
    chosen : list of Candidate
        One per output.
    recs : dict of str to Recording
        The recordings; the validation ones judge the fixed-point loss.
    actuator : str
        Names the signals.
    val_names : list of str
        Validation recordings.
    rate_hz : int
        Sample rate (Hz).

    Returns
    -------
    structure : EstimatorStructure
        The floating-point structure.
    result : QuantResult
        The blob and its report.
    """
    inputs, outputs, _ = SIGNALS[actuator]
    chains = [c.model.to_structure() for c in chosen]
    structure = EstimatorStructure(
        tuple(inputs),
        tuple(o for c in chains for o in c.outputs),
        1.0 / rate_hz,
        meta={"actuator": actuator},
        input_units=("dR/100",) * len(inputs),
    )
    qrecs = [
        (n, np.column_stack([recs[n][c] / 100.0 for c in inputs]), np.column_stack([recs[n][o] for o in outputs]))
        for n in val_names
    ]
    capacity = FLASH_BLOB_MAX if actuator in PAPER_ORDERS else MAX_BLOB_LEN
    return structure, quantize(structure, recordings=qrecs, capacity=capacity)


def store_model(dev, blob: bytes, upload=None, *, watchdog_ms: int | None = None, log=print):
    """Store a model blob on the board.

    Over the protocol into the EEPROM when it fits there beside the running model, else into
    the flash model store with ``upload(pages)`` (the slot that is not running, next commit
    counter).

    Parameters
    ----------
    dev : Device
        The board.
    blob : bytes
        The model blob.
    upload : callable, optional
        ``upload(pages)`` of a simulated board (:attr:`porosense.boards.OpenBoard.upload`); a
        blob that needs the flash store cannot be stored without it.
    watchdog_ms : int, optional
        Link watchdog (ms of board time) to set again after an upload has reset the board.
    log : callable
        Receives one line.

    Returns
    -------
    ModelInfo
        The board's MODEL_INFO afterwards.
    """
    running = dev.model_info()
    room = AREA_LEN - running.length if running.valid and running.store == "eeprom" else AREA_LEN
    if len(blob) <= room:
        info = dev.write_model(blob, replace=False)
        log(f"  flashed into the EEPROM: {info}")
        return info
    if upload is None:
        raise ModelError(
            f"the {len(blob)}-byte model needs the flash store (room in the EEPROM: {room} bytes): "
            "upload it with porosense flash --store flash"
        )
    plan, info = flash_upload(dev, blob, upload)
    # The upload reset the board: R0 again, and the link watchdog (RAM only) when one was set.
    dev.calibrate_r0(n_samples=32, channels=(1 << info.n_inputs) - 1)
    if watchdog_ms is not None:
        dev.set_watchdog(watchdog_ms)
    if not info.valid or info.store != "flash" or info.length != len(blob):
        raise DeviceError(f"uploaded flash slot {plan.slot} but the board runs: {info}")
    log(f"  uploaded into flash slot {plan.slot} ({len(blob)} bytes, more than the EEPROM's {room}-byte room): {info}")
    return info


def verify_by_replay(dev, blob, rec, inputs, *, n_max: int = 1000, log=print) -> dict:
    """Replay a recording's inputs through the board's estimator and the bit-exact reference.

    Parameters
    ----------
    dev : Device
        The board, running ``blob``.
    blob : ModelBlob
        The model the board runs.
    rec : Recording
        Its input columns (dR, %) are replayed.
    inputs : list of str
        The input columns.
    n_max : int
        Samples replayed at most.
    log : callable
        Receives one line.

    Returns
    -------
    dict
        ``samples`` replayed, ``mismatches`` (0) and ``bit_exact`` (True).

    Raises
    ------
    DeviceError
        When any estimate differs from the reference.
    """
    dr_centi = np.zeros((len(rec), 3), dtype=np.int16)
    for i, c in enumerate(inputs):
        dr_centi[:, i] = np.round(rec[c] * 100).astype(np.int16)
    n_replay = min(len(rec), n_max)
    on_dev = dev.replay(dr_centi[:n_replay])
    ref, _ = FixedPointEstimator(blob).run(dr_centi[:n_replay])
    mismatches = int(np.count_nonzero(np.asarray(on_dev) != ref))
    log(f"  verified by replay: {n_replay} samples, {mismatches} mismatches")
    if mismatches:
        raise DeviceError(f"device estimates differ from the reference in {mismatches} of {n_replay} samples")
    return {"samples": n_replay, "mismatches": mismatches, "bit_exact": True}


def _live_fit(outputs):
    """Running fit (%) of the on-device estimates against the truth, for the progress bar."""

    def monitor(rows: dict) -> str:
        parts = []
        for o in outputs:
            y, e = rows.get(o), rows.get(f"est_{o}")
            if y is None or len(y) < 50 or np.ptp(y) == 0:
                return ""
            parts.append(f"{o} fit {fit_percent(y, e):.1f}%")
        return ", ".join(parts)

    return monitor
