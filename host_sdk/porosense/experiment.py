"""Run an experiment schedule on a board and record it.

The host streams SAMPLE frames and, as the device clock passes each change of the schedule,
sends SET_OUTPUTS, so the schedule runs on device time whatever the link's speed. The result
is a :class:`porosense.data.Recording` with the commanded pressures, the ADC counts, dR, the
IMU angles, the on-device estimates and, when the back-end knows it, the ground truth.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack

import numpy as np

from porosense.data import Recording
from porosense.data.sample_log import SampleLog
from porosense.device import Device
from porosense.errors import DeviceError
from porosense.sim.schedules import Schedule

#: Device time (s) after which a silent host pings, well inside the 1 s host-link watchdog.
KEEPALIVE_S = 0.25

#: Ground truth by device time: maps an array of device times (us) to named columns.
TruthSource = Callable[[np.ndarray], dict]


def run_schedule(
    dev: Device,
    schedule: Schedule,
    *,
    rate_hz: int = 50,
    n_channels: int = 1,
    truth: TruthSource | None = None,
    progress: bool = False,
    meta: dict | None = None,
    out_scale=None,
    output_names=None,
    monitor: Callable[[dict], str] | None = None,
    log_path=None,
) -> Recording:
    """Run ``schedule`` on ``dev`` at ``rate_hz`` (Hz) and return the recording.

    ``truth`` adds ground-truth columns (``<name>_true`` where the device measures the same
    quantity, e.g. dR_0_true); ``out_scale`` (units per LSB) and ``output_names``
    turn the on-device estimates into ``est_<name>`` columns. ``monitor`` receives the columns
    recorded so far (truth and estimates) every two seconds of device time and returns a short text
    for the progress bar (e.g. a running fit). Outputs are switched off at the end, even when
    the run fails. ``log_path`` (CSV) receives every sample's raw columns as it arrives, flushed
    at least once a second, so a run killed midway leaves what it recorded there.
    """
    with ExitStack() as stack:
        log = stack.enter_context(SampleLog(log_path, _log_columns(n_channels))) if log_path else None
        return _run(dev, schedule, rate_hz, n_channels, truth, progress, meta, out_scale, output_names, monitor, log)


def _log_columns(n_channels: int) -> list[str]:
    """Columns of the on-the-fly log: device time, ADC counts and dR per channel, status."""
    return ["t_dev_us", *(f"adc_{c}" for c in range(n_channels)), *(f"dR_{c}" for c in range(n_channels)), "status"]


def _log_row(s, n_channels: int) -> tuple:
    adc = [int(s.adc[c]) for c in range(n_channels)]
    dr = [s.dr_centi[c] / 100.0 for c in range(n_channels)]
    return (int(s.t_us), *adc, *dr, int(s.status))


def _run(dev, schedule, rate_hz, n_channels, truth, progress, meta, out_scale, output_names, monitor, log):
    n_total = int(round(schedule.duration_s * rate_hz))
    changes = _change_times(schedule)
    dev.set_outputs(setpoint_kpa=[0.0, 0.0, 0.0], pumps=0, valves=0)
    dev.start_stream(rate_hz=rate_hz)
    bar = _bar(progress, n_total, schedule.name)
    rows = []
    t0 = None
    k_change = 0
    last_cmd_t = 0.0
    try:
        for s in dev.samples(n_total):
            if t0 is None:
                t0 = s.t_us
            t = (s.t_us - t0) * 1e-6
            # Apply every change that is due by this sample's device time.
            while k_change < len(changes) and changes[k_change] <= t + 1e-9:
                k_change += 1
                _apply(dev, schedule, changes[k_change - 1])
                last_cmd_t = t
            if t - last_cmd_t >= KEEPALIVE_S:
                dev.ping()  # keeps the host-link watchdog from cutting the outputs
                last_cmd_t = t
            rows.append(s)
            if log is not None:
                log.append(_log_row(s, n_channels))
            if bar is not None:
                bar.update(1)
                if monitor is not None and len(rows) % (2 * rate_hz) == 0:
                    text = monitor(_columns(rows, truth, out_scale, output_names))
                    if text:
                        bar.set_postfix_str(text, refresh=False)
    finally:
        try:
            dev.set_outputs(setpoint_kpa=[0.0, 0.0, 0.0], pumps=0, valves=0)
            dev.stop_stream()
        except DeviceError:
            pass
        if bar is not None:
            bar.close()
    if not rows:
        raise DeviceError(f"no samples recorded from {dev.url}")
    t_us = np.array([s.t_us for s in rows], dtype=np.int64)
    t = (t_us - t_us[0]) * 1e-6
    cols: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    setpoints = schedule.setpoints(t)
    adc = np.array([s.adc for s in rows], dtype=float)
    dr = np.array([s.dr_centi for s in rows], dtype=float) / 100.0
    for c in range(n_channels):
        cols[f"p_cmd_{c}"], units[f"p_cmd_{c}"] = setpoints[:, c], "kPa"
        cols[f"adc_{c}"], units[f"adc_{c}"] = adc[:, c], "counts"
        cols[f"dR_{c}"], units[f"dR_{c}"] = dr[:, c], "%"
    euler = np.array([s.euler_16 for s in rows], dtype=float) / 16.0
    if n_channels == 3:
        for i, name in enumerate(("imu_heading", "imu_roll", "imu_pitch")):
            cols[name], units[name] = euler[:, i], "deg"
    cols["t_dev_us"], units["t_dev_us"] = t_us.astype(float), "us"
    cols["status"], units["status"] = np.array([s.status for s in rows], dtype=float), "flags"
    if output_names:
        est = np.array([s.estimate for s in rows], dtype=float)
        scale = np.asarray(out_scale if out_scale is not None else np.ones(3), dtype=float)
        for j, name in enumerate(output_names):
            cols[f"est_{name}"] = est[:, j] * scale[j]
    if truth is not None:
        for name, values in truth(t_us).items():
            # The device's own measurements (dR) stay: models are identified and judged on
            # what the estimator will see; a ground-truth copy goes to <name>_true.
            cols[f"{name}_true" if name in cols else name] = np.asarray(values, dtype=float)
    lost = dev.stats.samples_lost if hasattr(dev, "stats") else 0
    info = {
        "schedule": schedule.name,
        "rate_hz": rate_hz,
        "device": dev.url,
        "samples_lost": int(lost),
        "schedule_data": schedule.to_dict(),
    }
    info.update(meta or {})
    return Recording(t, cols, meta=info, units=units)


def _columns(rows, truth, out_scale, output_names) -> dict:
    """Truth and estimate columns of the samples so far (for a live monitor)."""
    cols = {}
    if truth is not None:
        cols.update(truth(np.array([s.t_us for s in rows], dtype=np.int64)))
    if output_names:
        est = np.array([s.estimate for s in rows], dtype=float)
        scale = np.asarray(out_scale if out_scale is not None else np.ones(3), dtype=float)
        for j, name in enumerate(output_names):
            cols[f"est_{name}"] = est[:, j] * scale[j]
    return cols


def _change_times(schedule: Schedule) -> list[float]:
    times = sorted({float(tc) for ch in schedule.changes for tc, _ in ch})
    return times


def _apply(dev: Device, schedule: Schedule, t: float) -> None:
    sp, pump, valve = schedule.actuation(np.array([t]))
    mask_p = sum(1 << c for c in range(3) if pump[0, c])
    mask_v = sum(1 << c for c in range(3) if valve[0, c])
    dev.set_outputs(setpoint_kpa=list(sp[0]), pumps=mask_p, valves=mask_v)


def _bar(enabled: bool, total: int, name: str):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=f"  {name}", unit="sample", leave=False, dynamic_ncols=True)
