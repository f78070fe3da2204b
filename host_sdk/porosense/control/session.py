"""Run targets on a board and record what happened.

:func:`run_closed_loop` streams while the board's controller follows constant targets (one
per segment, switched on device time) or a stored trajectory; :func:`run_open_loop` streams
while the host commands vacuum levels (the baseline). Both ping the board between commands so
that its link watchdog stays fed, and always vent at the end (stop_control / outputs off),
also when the run fails.

The result is a :class:`porosense.data.Recording` with ``t`` (s from the first sample),
``target_0`` (the board's own target, output units, NaN when not controlling), ``est_<output>``
(the on-device estimate), ``cmd_kpa_0`` (the regulator setpoint commanded, kPa), ``status``,
``dR_0`` and, where the back-end knows it, the truth (``<output>`` e.g. ``strain_0``).
"""

from __future__ import annotations

import math

import numpy as np

from porosense.data import Recording
from porosense.errors import DeviceError
from porosense.protocol import StatusFlag

#: Status flags that say the board cut the outputs.
VENT_FLAGS = int(StatusFlag.WATCHDOG_TRIPPED | StatusFlag.CONTROL_ABORTED)

#: Device time (s) after which a silent host pings, well inside the host-link watchdog.
KEEPALIVE_S = 0.25


def _stream(dev, duration_s: float, rate_hz: int, events, keepalive_s: float = KEEPALIVE_S, on_sample=None) -> list:
    """Stream ``duration_s`` of device time; ``events`` is a sorted list of (t_s, callable)
    run as the device clock passes t_s; ``on_sample(sample)`` sees each sample as it arrives
    (a log on disk). Returns the samples."""
    n_total = int(round(duration_s * rate_hz))
    rows = []
    t0 = None
    k = 0
    last = 0.0
    for s in dev.samples(n_total):
        if t0 is None:
            t0 = s.t_us
        t = (s.t_us - t0) * 1e-6
        while k < len(events) and events[k][0] <= t + 1e-9:
            events[k][1]()
            k += 1
            last = t
        if t - last >= keepalive_s:
            dev.ping()
            last = t
        rows.append(s)
        if on_sample is not None:
            on_sample(s)
    return rows


def _recording(rows, *, out_scale, output, truth, host_target=None, host_cmd=None, meta=None, t=None) -> Recording:
    if not rows:
        raise DeviceError("no samples recorded")
    t_us = np.array([s.t_us for s in rows], dtype=np.int64)
    t = (t_us - t_us[0]) * 1e-6 if t is None else np.asarray(t, dtype=float)
    cols = {}
    units = {}
    board_target = np.array([_first(getattr(s, "target", None)) for s in rows], dtype=float)
    cols["target_0"] = board_target if host_target is None else np.asarray(host_target, dtype=float)
    est = np.array([s.estimate[0] for s in rows], dtype=float) * float(out_scale)
    cols[f"est_{output}"] = est
    cmd = np.array([_first(getattr(s, "command_kpa", None)) for s in rows], dtype=float)
    cols["cmd_kpa_0"] = cmd if host_cmd is None else np.asarray(host_cmd, dtype=float)
    cols["dR_0"] = np.array([s.dr_centi[0] for s in rows], dtype=float) / 100.0
    cols["status"] = np.array([s.status for s in rows], dtype=float)
    cols["t_dev_us"] = t_us.astype(float)
    units.update({"cmd_kpa_0": "kPa", "dR_0": "%", "status": "flags", "t_dev_us": "us"})
    if truth is not None:
        values = truth(t_us)
        if output in values:
            cols[output] = np.asarray(values[output], dtype=float)
        if "p_0" in values:
            cols["p_0"] = np.asarray(values["p_0"], dtype=float)
            units["p_0"] = "kPa"
    meta = dict(meta or {})
    status = cols["status"].astype(int)
    meta["vented_samples"] = int(np.count_nonzero(status & VENT_FLAGS))
    return Recording(t, cols, meta=meta, units=units)


def check_not_vented(rec) -> None:
    """DeviceError when the board cut the outputs during ``rec`` (link watchdog, sensor fault or
    a saturated estimator): the run did not measure what it was meant to."""
    n = rec.meta.get("vented_samples", 0)
    if n:
        raise DeviceError(
            f"the board vented during the run ({n} samples flagged WATCHDOG_TRIPPED or "
            "CONTROL_ABORTED: host link lost, sensor fault or estimator saturated)"
        )


def _first(v):
    if v is None:
        return math.nan
    try:
        return float(v[0])
    except TypeError:
        return float(v)


#: Duration (s) of the jump between two held targets of a step sequence's trajectory (the
#: trajectory's time step is 10 ms; the board's slew limit shapes the rest).
JUMP_S = 0.01


def step_trajectory(segments, end_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear points holding each target of ``segments`` [(t_s, target), ...] until the
    next (times relative to the first segment), up to ``end_s`` (same clock as the segments)."""
    t0 = float(segments[0][0])
    ts, ys = [], []
    for i, (t, v) in enumerate(segments):
        start = float(t) - t0
        if i:
            ts.append(start - JUMP_S)
            ys.append(ys[-1])
        ts.append(start)
        ys.append(float(v))
    ts.append(float(end_s) - t0)
    ys.append(ys[-1])
    return np.round(np.array(ts), 2), np.array(ys)


def run_closed_loop(
    dev,
    segments,
    *,
    rate_hz: int,
    out_scale: float,
    output: str = "strain_0",
    truth=None,
    channels: int = 0b001,
    duration_s: float | None = None,
    trajectory=None,
    meta: dict | None = None,
    on_sample=None,
) -> Recording:
    """Closed loop on the board, on device time (s from the first streamed sample):

    - one segment [(t_s, target)]: a constant target (output units) from t_s;
    - several: held targets switched at each t_s, sent as a stored trajectory (the board times
      the switches; restarting control per target would vent in between);
    - ``trajectory`` = (t_s, targets): that stored trajectory, started at t = 0.

    Runs until ``duration_s`` (default: the last segment + 10 s, or the trajectory's end) and
    vents at the end. ``on_sample(sample)`` sees each sample as it arrives."""
    start_at = 0.0
    if trajectory is None and len(segments) > 1:
        if duration_s is None:
            duration_s = float(segments[-1][0]) + 10.0
        start_at = float(segments[0][0])
        trajectory = step_trajectory(segments, duration_s)
    if trajectory is not None:
        if duration_s is None:
            duration_s = float(np.asarray(trajectory[0])[-1])
        dev.write_trajectory(*trajectory)  # before streaming: the board stores it only when idle
        events = [(start_at, lambda: dev.start_trajectory(channels=channels))]
    else:
        if duration_s is None:
            duration_s = float(segments[-1][0]) + 10.0
        events = [(float(segments[0][0]), lambda v=float(segments[0][1]): dev.start_control(v, channels=channels))]
    dev.set_outputs(setpoint_kpa=[0.0, 0.0, 0.0], pumps=0, valves=0)
    dev.start_stream(rate_hz=rate_hz)
    try:
        rows = _stream(dev, duration_s, rate_hz, events, on_sample=on_sample)
    finally:
        _vent(dev, control=True)
    info = {
        "mode": "closed_loop",
        "rate_hz": rate_hz,
        "device": getattr(dev, "url", ""),
        "segments": [list(map(float, s)) for s in segments] if segments else [],
    }
    info.update(meta or {})
    return _recording(rows, out_scale=out_scale, output=output, truth=truth, meta=info)


def run_open_loop(
    dev,
    segments,
    *,
    rate_hz: int,
    out_scale: float = 1.0,
    output: str = "strain_0",
    truth=None,
    duration_s: float | None = None,
    targets=None,
    meta: dict | None = None,
) -> Recording:
    """Open loop: ``segments`` [(t_s, vacuum_kpa >= 0), ...] each held until the next (the last
    until ``duration_s``, default + 10 s); 0 vents. ``targets`` (one per segment, output units)
    are recorded in ``target_0`` for the metrics.

    Each hold is commanded with streaming off and then streamed for its length, so the samples
    of a hold start exactly at its command whatever the host's delay (the board has no
    pressure schedule of its own; a late host only lengthens the previous hold unrecorded)."""
    if duration_s is None:
        duration_s = float(segments[-1][0]) + 10.0
    ends = [float(t) for t, _ in segments[1:]] + [float(duration_s)]
    rows, vac, tgt, times = [], [], [], []
    try:
        for i, ((t0, v), t1) in enumerate(zip(segments, ends)):
            on = v > 0
            dev.set_outputs(setpoint_kpa=[-float(v), 0.0, 0.0], pumps=int(on), valves=int(on))
            dev.start_stream(rate_hz=rate_hz)
            part = _stream(dev, t1 - float(t0), rate_hz, [])
            dev.stop_stream()
            dev.drain_samples()
            rows += part
            times += (float(t0) + np.arange(len(part)) / float(rate_hz)).tolist()
            vac += [float(v)] * len(part)
            tgt += [float(targets[i]) if targets is not None else np.nan] * len(part)
    finally:
        _vent(dev, control=False)
    info = {
        "mode": "open_loop",
        "rate_hz": rate_hz,
        "device": getattr(dev, "url", ""),
        "segments": [list(map(float, s)) for s in segments],
    }
    info.update(meta or {})
    return _recording(
        rows,
        out_scale=out_scale,
        output=output,
        truth=truth,
        host_target=tgt if targets is not None else None,
        host_cmd=-np.asarray(vac),
        meta=info,
        t=times,
    )


def _vent(dev, *, control: bool) -> None:
    """Outputs to vent and streaming off, whatever happened before (errors here are moot)."""
    try:
        if control:
            dev.stop_control()
        dev.set_outputs(setpoint_kpa=[0.0, 0.0, 0.0], pumps=0, valves=0)
        dev.stop_stream()
    except DeviceError:
        pass
