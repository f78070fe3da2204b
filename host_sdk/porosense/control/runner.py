"""One control run as ``porosense control run`` does it: open the board, flash and set gains,
run a constant target or a trajectory, measure.

A simulated board (emulator / simboard) starts fresh: its R0 is calibrated at rest first (as
``porosense demo`` does). A real board keeps its stored R0 and gains unless given.
"""

from __future__ import annotations

import math
from contextlib import ExitStack
from dataclasses import dataclass, field

import numpy as np

from porosense.boards import SIM_WATCHDOG_MS, open_board
from porosense.control.metrics import StepMetrics, TrackingMetrics, step_metrics, tracking_metrics
from porosense.control.session import run_closed_loop
from porosense.control.tuning import PiGains
from porosense.data.sample_log import SampleLog
from porosense.device import ControlGains
from porosense.errors import DeviceError, InputError
from porosense.files import save_figure

#: Rest streamed before a constant target (s): the start of the step is measured there.
LEAD_S = 1.0


@dataclass
class RunRequest:
    """What to run: ``port`` (URL or emulator/simboard[:ACTUATOR]), a constant ``target`` (output
    units) held ``hold_s`` s or a ``trajectory`` (t_s, targets), ``gains`` (None: the board's),
    ``model`` blob bytes to flash first (None: the board's), ``load_g`` and ``seed`` of a
    simulated board."""

    port: str
    target: float | None = None
    hold_s: float = 10.0
    trajectory: tuple | None = None
    gains: PiGains | None = None
    model: bytes | None = None
    load_g: float = 0.0
    seed: int = 0
    output: str = "strain_0"
    log_path: str | None = None  # a CSV written sample by sample while the run goes on
    physics: object = None  # porosense.sim.Physics of a simulated board (None: the built-in ones)


#: Columns of the run's log on disk (device time, the on-device estimate and target in estimate
#: LSB, regulator command, dR, status flags): what a run killed midway leaves.
LOG_COLUMNS = ("t_dev_us", "estimate_0", "target_lsb_0", "cmd_kpa_0", "dR_0", "status")


def _log_row(s) -> tuple:
    target = s.target_lsb[0] if s.target_lsb is not None else float("nan")
    return (int(s.t_us), int(s.estimate[0]), target, float(s.command_kpa[0]), s.dr_centi[0] / 100.0, int(s.status))


@dataclass
class RunResult:
    """The recording of a run and its metrics (``against``: 'truth' or 'estimate')."""

    recording: object
    tracking: TrackingMetrics
    step: StepMetrics | None
    against: str
    output: str
    gains_on_board: list = field(default_factory=list)
    rate_hz: int = 0

    def to_dict(self) -> dict:
        return {
            "tracking": self.tracking.to_dict(),
            "step": self.step.to_dict() if self.step else None,
            "against": self.against,
            "output": self.output,
            "gains_on_board": self.gains_on_board,
            "rate_hz": self.rate_hz,
            "samples": len(self.recording),
            "vented_samples": self.recording.meta.get("vented_samples", 0),
        }

    def summary_lines(self) -> list[str]:
        tr = self.tracking
        lines = []
        vented = self.recording.meta.get("vented_samples", 0)
        if vented:
            lines.append(
                f"warning: the board vented during the run ({vented} samples flagged WATCHDOG_TRIPPED or "
                "CONTROL_ABORTED)"
            )
        lines += [
            f"tracking error against the {self.against} ({tr.n} samples): RMS {tr.rms:.3f}, peak {tr.peak:.3f} "
            f"({tr.rms_pct_of_target:.1f} % / {tr.peak_pct_of_target:.1f} % of the target)"
        ]
        if self.step is not None:
            s = self.step
            settle = "did not settle" if math.isnan(s.settling_s) else f"settled in {s.settling_s:.2f} s"
            lines.append(
                f"step {s.start:.2f} -> {s.target:g}: {settle} (2 % band), overshoot {s.overshoot_pct:.1f} %, "
                f"steady-state error {s.steady_error:+.3f}"
            )
        return lines

    def plot(self, path) -> None:
        plot_run(self.recording, path, output=self.output)


def plot_run(rec, path, *, output: str = "strain_0", title: str = "closed-loop run") -> None:
    """Target, estimate and true output against time (and the vacuum command below)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5), height_ratios=(2, 1))
    from porosense.data.units import axis_label
    from porosense.dsp.metrics import fit_percent

    ax.plot(rec.t, rec["target_0"], "k--", label="target")
    est = np.asarray(rec[f"est_{output}"], float)
    label = "on-device estimate"
    if output in rec:
        true = np.asarray(rec[output], float)
        ok = np.isfinite(est) & np.isfinite(true)
        if ok.sum() > 2 and np.ptp(true[ok]) > 0:
            label += f" (fit {fit_percent(true[ok], est[ok]):.1f} % to the true {output})"
    ax.plot(rec.t, est, label=label)
    if output in rec:
        ax.plot(rec.t, rec[output], label=f"true {output}", alpha=0.8)
    ax.set_ylabel(axis_label(output, rec.units))
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title)
    ax2.plot(rec.t, rec["cmd_kpa_0"], color="C3")
    ax2.set_ylabel("command (kPa)")
    ax2.set_xlabel("time (s)")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def prepare_board(dev, *, simulated: bool, model: bytes | None, gains: PiGains | None) -> tuple[int, float]:
    """Make a board ready for a control run.

    Parameters
    ----------
    dev : Device
        The board.
    simulated : bool
        A simulated board: calibrate R0 at rest and set the longest link watchdog.
    model : bytes or None
        A model blob to flash first (the board's rate is set to the model's); None keeps the
        board's model.
    gains : PiGains or None
        Gains to send; None keeps the board's.

    Returns
    -------
    rate_hz : int
        The board's sample rate (Hz).
    out_scale : float
        Output units per estimate LSB of output 0.
    """
    dev.hello()
    if model is not None:
        dev.check_model_rate(model, set_rate=True)
        dev.write_model(model, replace=True)
    info = dev.model_info()
    if not info.valid:
        raise DeviceError("the board has no model: flash one (porosense flash, or --model MODEL.bin)")
    if simulated:
        dev.calibrate_r0(n_samples=32, channels=0b001)
        # The simulated board may run faster than the wall clock (boards.EMULATOR_SPEED): a short
        # pause of this computer would be seconds of board time, past the 1 s default. RAM only.
        dev.set_watchdog(SIM_WATCHDOG_MS)
    if gains is not None:
        try:
            dev.set_control_gains(ControlGains(gains.kp_kpa, gains.ki_kpa_per_s, gains.slew_per_s))
        except InputError as exc:
            raise InputError(
                f"{exc}: re-tune with 'porosense control tune ... --model MODEL.bin' (it picks the "
                "smallest tau_cl the board holds) or a larger --tau-cl"
            ) from None
    return dev.sample_rate_hz(), float(info.out_scale[0])


def execute_run(req: RunRequest, log=print) -> RunResult:
    """Run a control request on the board it names and measure it.

    Parameters
    ----------
    req : RunRequest
        The board, the target or trajectory, the gains and the model.
    log : callable
        Receives one line before the run.

    Returns
    -------
    RunResult
        The recording and its metrics against the truth (simulated boards) or the estimate.
    """
    with ExitStack() as stack:
        sample_log = stack.enter_context(SampleLog(req.log_path, LOG_COLUMNS)) if req.log_path else None
        on_sample = (lambda s: sample_log.append(_log_row(s))) if sample_log else None
        rec, on_board, rate = _execute(req, log, on_sample)
    return measure(rec, req, on_board, rate)


def _execute(req: RunRequest, log, on_sample):
    with open_board(req.port, load_g=req.load_g, seed=req.seed, physics=req.physics) as board:
        dev, truth = board.device, board.truth
        rate, scale = prepare_board(dev, simulated=board.simulated, model=req.model, gains=req.gains)
        on_board = [g.__dict__ if hasattr(g, "__dict__") else str(g) for g in _gains_on_board(dev)]
        if req.trajectory is not None:
            t_s, targets = req.trajectory
            log(f"running a trajectory of {len(t_s)} points over {t_s[-1]:g} s at {rate} Hz")
            rec = run_closed_loop(
                dev,
                [],
                rate_hz=rate,
                out_scale=scale,
                output=req.output,
                truth=truth,
                trajectory=(t_s, targets),
                duration_s=float(t_s[-1]),
                on_sample=on_sample,
            )
        else:
            log(f"holding {req.target:g} for {req.hold_s:g} s at {rate} Hz")
            rec = run_closed_loop(
                dev,
                [(LEAD_S, req.target)],
                rate_hz=rate,
                out_scale=scale,
                output=req.output,
                truth=truth,
                duration_s=LEAD_S + req.hold_s,
                on_sample=on_sample,
            )
    return rec, on_board, rate


def _gains_on_board(dev) -> list:
    try:
        return list(dev.control_gains())
    except (DeviceError, AttributeError):
        return []


def measure(rec, req: RunRequest, on_board=(), rate: int = 0) -> RunResult:
    """Metrics of a run recording against the truth where present, else the estimate."""
    against = "truth" if req.output in rec else "estimate"
    y = rec[req.output] if against == "truth" else rec[f"est_{req.output}"]
    target = rec["target_0"]
    tracking = tracking_metrics(target, y)
    step = None
    if req.trajectory is None:
        on = np.isfinite(target)
        if on.any():
            t0 = float(rec.t[np.argmax(on)])
            before = rec.t < t0
            start = float(np.mean(y[before])) if before.any() else 0.0
            step = step_metrics(rec.t, req.target, y, t0, float(rec.t[-1]) - t0 + 1e-9, start)
    return RunResult(rec, tracking, step, against, req.output, list(on_board), rate)
