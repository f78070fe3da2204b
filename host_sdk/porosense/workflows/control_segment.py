"""The demo's closing act: tune from the demo's own recordings, send the gains, run a few steps.

Targets are fractions of the largest output the recordings reached (so the steps span the
stroke whatever the actuator), held long enough to settle. Single-channel actuators only
(contractor, bending): the 3-DoF segment's three outputs couple through one pose.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from porosense.boards import SIM_WATCHDOG_MS
from porosense.control.metrics import step_metrics, tracking_metrics
from porosense.control.plant import fit_fopdt
from porosense.control.session import VENT_FLAGS, run_closed_loop
from porosense.control.tuning import DEFAULT_TAU_CL_S, board_tau_cl, lambda_pi, predict_step
from porosense.device import ControlGains

#: Targets as fractions of the largest output recorded, each held HOLD_S.
FRACTIONS = (0.35, 0.7, 0.5)
HOLD_S = 6.0
LEAD_S = 1.0


def _regular(rec, output: str, ts: float):
    """(vacuum kPa, output) of ``rec`` on a regular grid of period ``ts``: a busy host loses
    samples on a real-time board, and the FOPDT fit counts time in samples. The command is held
    (it is piecewise constant), the output interpolated."""
    t = np.asarray(rec.t, dtype=float)
    grid = np.arange(0.0, t[-1] + 1e-9, ts)
    idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
    return -np.asarray(rec["p_cmd_0"], dtype=float)[idx], np.interp(grid, t, rec[output])


@dataclass
class DemoControl:
    """The segment's figures: the plant, the gains, per step the settling time (s), overshoot (%)
    and steady-state error (output units) against the truth, and the tracking RMS."""

    plant: dict
    gains: dict
    predicted: dict
    steps: list
    tracking: dict
    output: str

    def to_dict(self) -> dict:
        return asdict(self)

    def summary(self) -> str:
        errs = ", ".join(f"{s['target']:.3g}: {s['steady_error']:+.3f}" for s in self.steps)
        return (
            f"closed loop on {self.output}: kp {self.gains['kp_kpa']:.3g}, ki {self.gains['ki_kpa_per_s']:.3g}; "
            f"steady-state error per target ({errs}); tracking RMS {self.tracking['rms']:.3f}"
        )


def run_segment(dev, truth, recs: dict, output: str, out_scale: float, rate_hz: int, log=print):
    """Tune PI gains on the demo's recordings, send them and run a few targets on the board.

    Parameters
    ----------
    dev : Device
        The board, running the demo's model.
    truth : TruthSource or None
        True outputs by device time (a simulated board; its watchdog is then set to
        SIM_WATCHDOG_MS), else None.
    recs : dict of str to Recording
        Recordings with the vacuum command ``p_cmd_0`` (kPa) and ``output``.
    output : str
        The controlled output (``strain_0`` in %, ``curvature`` in 1/m).
    out_scale : float
        Output units per estimate LSB of the board's model.
    rate_hz : int
        Sample rate (Hz).
    log : callable
        Receives the segment's lines.

    Returns
    -------
    control : DemoControl
        The plant, the gains, the predicted step and per target the settling time (s),
        overshoot (%) and steady-state error (output units).
    run : Recording
        The closed-loop run.
    """
    # Recordings in which the board cut the outputs (its link watchdog, on a busy computer) do
    # not show what the command did: tune on the others.

    clean = [n for n in recs if not np.any(np.asarray(recs[n]["status"], dtype=int) & VENT_FLAGS)]
    names = clean or list(recs)
    if len(clean) < len(recs):
        log(
            f"  control: tuning on {len(clean)} of {len(recs)} recordings (the others have outputs cut by the "
            "board's watchdog)"
        )
    ts = 1.0 / rate_hz
    vac, ys = zip(*(_regular(recs[n], output, ts) for n in names))
    plant = fit_fopdt(vac, ys, ts, output_unit="%" if "strain" in output else "")
    top = float(max(np.max(recs[n][output]) for n in names))
    slew = top / 1.0  # the whole stroke in a second at most
    tau = board_tau_cl(plant, DEFAULT_TAU_CL_S, slew, out_scale, rate_hz)
    gains = lambda_pi(plant, tau, slew)
    targets = [round(f * top, 2) for f in FRACTIONS]
    pred = predict_step(plant, gains, targets[0])
    log(
        f"  control: {plant}; kp {gains.kp_kpa:.3g} kPa/unit, ki {gains.ki_kpa_per_s:.3g} kPa/(unit s) "
        f"(lambda rule, tau_cl {tau:.3g} s); predicted step settles in {pred.settling_s:.2f} s"
    )
    if truth is not None:  # a simulated board: its clock runs faster than this computer's
        dev.set_watchdog(SIM_WATCHDOG_MS)
    dev.set_control_gains(ControlGains(gains.kp_kpa, gains.ki_kpa_per_s, gains.slew_per_s))
    segs = [(LEAD_S + i * HOLD_S, v) for i, v in enumerate(targets)]
    rec = run_closed_loop(
        dev,
        segs,
        rate_hz=rate_hz,
        out_scale=out_scale,
        output=output,
        truth=truth,
        duration_s=LEAD_S + len(targets) * HOLD_S,
    )
    y = rec[output] if output in rec else rec[f"est_{output}"]
    steps, prev = [], float(np.mean(y[rec.t < LEAD_S]))
    for t0, v in segs:
        steps.append(step_metrics(rec.t, v, y, t0, HOLD_S, prev).to_dict())
        prev = v
    result = DemoControl(
        plant.to_dict(), gains.to_dict(), pred.summary(), steps, tracking_metrics(rec["target_0"], y).to_dict(), output
    )
    log(f"  {result.summary()}")
    return result, rec
