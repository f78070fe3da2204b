"""Run one of the paper's experiments on a simulated actuator and record it.

The recording holds what the paper measured: commanded and chamber pressure, ADC counts, the
resistance and dR computed from the counts (R0 calibrated over the first second of rest, as
the device does), and the ground truth from the instruments: marker tracking at the camera
frame rate (strain, curvature, dz) and BNO055 angles (theta_x, theta_y).
"""

from __future__ import annotations

import numpy as np

from porosense.data import Recording
from porosense.errors import InputError
from porosense.sim.electronics import adc_counts, counts_to_voltage, resistance_from_voltage
from porosense.sim.plant import OUTPUT_UNITS, OUTPUTS, make_plant
from porosense.sim.schedules import THREE_DOF_ONLY, Schedule, schedule

R0_CALIBRATION_S = 1.0


def _camera(
    values: np.ndarray, t: np.ndarray, fps: float, noise: float, rng, noisy: bool, lag_s: float = 0.0
) -> np.ndarray:
    """Sample and hold at the frame rate, with independent noise per frame; each frame shows
    the state ``lag_s`` seconds before its time stamp (the camera's latency against the board)."""
    if lag_s != 0.0:
        values = np.interp(t - lag_s, t, values)
    frame = np.floor(t * fps + 1e-9).astype(int)
    first = np.r_[True, frame[1:] != frame[:-1]]
    held = values[np.maximum.accumulate(np.where(first, np.arange(t.size), 0))]
    if noisy:
        per_frame = rng.standard_normal(frame.max() - frame.min() + 1) * noise
        held = held + per_frame[frame - frame.min()]
    return held


def run_experiment(
    actuator: str,
    experiment,
    *,
    porosity=None,
    load_g: float = 0.0,
    rate_hz: float = 100.0,
    seed: int = 0,
    effects=None,
    physics=None,
    noise: bool = True,
    specimen: int = 0,
) -> Recording:
    """Simulate one of the paper's experiments on an actuator and record it.

    Parameters
    ----------
    actuator : str
        ``"contractor"``, ``"bending"`` or ``"3dof"``.
    experiment : str or Schedule
        A schedule name (:func:`experiment_names`) or a schedule.
    porosity : float or None
        Porosity, % (None: the actuator's default).
    load_g : float
        Hanging load, g.
    rate_hz : float
        Sample rate, Hz.
    seed : int
        Seed of the recording (noise, drift, softening state).
    effects : list of str, dict or None
        Named extra effects (porosense.sim.effects), off by default.
    physics : Physics or None
        Stage parameters (porosense.sim.params).
    noise : bool
        False for noiseless sensors.
    specimen : int
        The printed actuator (duplicates: one specimen, two seeds).

    Returns
    -------
    Recording
        ``p_cmd_c`` and ``p_c`` (kPa), ``adc_c`` (counts), ``R_c`` (ohm), ``dR_c`` (%, R0 from the
        first second of rest), the ground truth (``strain_0`` %, ``curvature`` 1/m, or
        ``theta_x``/``theta_y`` deg and ``dz`` mm) and ``load_g`` (g); dropped samples (the
        ``outliers`` effect) are missing rows.

    Raises
    ------
    InputError
        A sample rate <= 0, a 3-DoF experiment on another actuator, or a bad plant argument.
    """
    sched = experiment if isinstance(experiment, Schedule) else schedule(experiment)
    if not rate_hz > 0:
        raise InputError(f"sample rate must be positive, got {rate_hz} Hz")
    if actuator != "3dof" and sched.name.startswith(THREE_DOF_ONLY):
        raise InputError(f"experiment '{sched.name}' is for the 3dof segment, not the {actuator}")
    plant = make_plant(
        actuator,
        porosity=porosity,
        load_g=load_g,
        seed=seed,
        effects=effects,
        physics=physics,
        noise=noise,
        specimen=specimen,
    )
    n, ph = plant.n_channels, plant.physics
    t = sched.times(rate_hz)
    sp, pump, valve = sched.actuation(t)
    sim = plant.run(1.0 / rate_hz, sp, pump, valve)
    rng = np.random.default_rng([plant.seed, 1])

    counts = adc_counts(sim["voltage_V"][:, :n], ph.electronics)
    r_meas = resistance_from_voltage(counts_to_voltage(counts, ph.electronics), ph.electronics)
    n_cal = max(1, int(round(R0_CALIBRATION_S * rate_hz)))
    r0 = np.median(r_meas[:n_cal], axis=0)

    columns, units = {}, {}
    for c in range(n):
        columns[f"p_cmd_{c}"], units[f"p_cmd_{c}"] = sp[:, c], "kPa"
    for c in range(n):
        columns[f"p_{c}"], units[f"p_{c}"] = sim[f"p_{c}"], "kPa"
    for c in range(n):
        columns[f"adc_{c}"], units[f"adc_{c}"] = counts[:, c], "counts"
    for c in range(n):
        columns[f"R_{c}"], units[f"R_{c}"] = r_meas[:, c], "ohm"
    for c in range(n):
        columns[f"dR_{c}"], units[f"dR_{c}"] = (r_meas[:, c] - r0[c]) / r0[c] * 100.0, "%"

    sens = ph.sensors
    lag = sens.camera_lag_s + sens.camera_lag_jitter_s * (2.0 * rng.random() - 1.0) if noise else 0.0
    if actuator == "contractor":
        noise_pct = sens.marker_noise_mm / sens.contractor_length_mm * 100.0 * np.sqrt(2.0)
        columns["strain_0"] = _camera(sim["strain_0"], t, sens.camera_fps, noise_pct, rng, noise, lag)
    elif actuator == "bending":
        # curvature from three markers along the actuator: noise ~ marker noise / spacing^2
        noise_k = np.sqrt(6.0) * sens.marker_noise_mm * 1e-3 / (sens.bending_marker_spacing_mm * 1e-3) ** 2
        columns["curvature"] = _camera(sim["curvature"], t, sens.camera_fps, noise_k, rng, noise, lag)
    else:
        columns["theta_x"] = sim["euler_deg"][:, 1]
        columns["theta_y"] = sim["euler_deg"][:, 2]
        columns["dz"] = _camera(sim["dz"], t, sens.camera_fps, sens.segment_dz_noise_mm, rng, noise, lag)
    columns["load_g"] = sim["load_g"]
    units.update({k: OUTPUT_UNITS[k] for k in OUTPUTS[actuator]}, load_g="g")

    meta = {
        "source": "porosense.sim",
        "actuator": actuator,
        "experiment": sched.name,
        "porosity": plant.porosity,
        "load_g": plant.load_g,
        "rate_hz": float(rate_hz),
        "seed": plant.seed,
        "specimen": plant.specimen,
        "noise": bool(noise),
        "effects": plant.effects,
        "inputs": [f"dR_{c}" for c in range(n)],
        "truth": list(OUTPUTS[actuator]),
        "r0_ohm": r0.tolist(),
        "schedule": sched.to_dict(),
        "camera_fps": sens.camera_fps,
    }
    rec = Recording(t, columns, meta, units)
    if sim["dropped"].any():
        keep = ~sim["dropped"]
        rec = Recording(t[keep], {k: v[keep] for k, v in rec.columns.items()}, meta, units)
        rec.meta["dropped_samples"] = int((~keep).sum())
    return rec
