"""Pneumatics: regulated vacuum line, valve and chamber of one channel.

The chamber gauge pressure ``p`` (kPa, <= 0) moves first-order towards a target:

- valve open and pump on: the regulator setpoint (clipped to -80..0 kPa), time constant
  ``tau_fill_s``;
- valve open, pump off: the line slowly loses its vacuum (``tau_leak_s``) towards 0;
- valve closed: the chamber vents to atmosphere (``tau_vent_s``).

Each step is limited to ``max_rate_kpa_s * dt`` (the flow the pump or the vent can pass).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from porosense.sim.params import Pneumatics


def target_and_tau(setpoint_kpa: float, pump: bool, valve: bool, p: Pneumatics) -> tuple[float, float]:
    """Target pressure (kPa) and time constant (s) for one channel's actuation."""
    if valve:
        if pump:
            return min(max(setpoint_kpa, p.min_setpoint_kpa), 0.0), p.tau_fill_s
        return 0.0, p.tau_leak_s
    return 0.0, p.tau_vent_s


def step_pressure(pressure: float, dt: float, setpoint_kpa: float, pump: bool, valve: bool, p: Pneumatics) -> float:
    """Chamber pressure (kPa) after ``dt`` seconds."""
    target, tau = target_and_tau(setpoint_kpa, pump, valve, p)
    change = (target - pressure) * -math.expm1(-dt / tau)
    limit = p.max_rate_kpa_s * dt
    return pressure + (limit if change > limit else -limit if change < -limit else change)


def run_pressure(dt: float, setpoint_kpa, pump, valve, p: Pneumatics, p0: float = 0.0) -> np.ndarray:
    """Chamber pressure (kPa) for each sample of the actuation series (1-D arrays).

    The series depends only on the actuation and the pneumatics, not on the foam or the sensor,
    so a calibration that simulates the same records at many porosities computes it once: the
    last :data:`RUN_CACHE_SIZE` series are kept (keyed on the exact inputs; a new array is
    returned every call).

    Parameters
    ----------
    dt : float
        Sample period, s.
    setpoint_kpa : array_like, shape (N,)
        Regulator setpoint, kPa.
    pump, valve : array_like of bool, shape (N,)
        Pump and valve states.
    p : Pneumatics
        The line's parameters.
    p0 : float
        Chamber pressure before the first sample, kPa.

    Returns
    -------
    ndarray, shape (N,)
        Chamber pressure after each sample, kPa.
    """
    sp = np.ascontiguousarray(setpoint_kpa, dtype=float).ravel()
    pu = np.ascontiguousarray(pump, dtype=bool).ravel()
    va = np.ascontiguousarray(valve, dtype=bool).ravel()
    key = (float(dt), sp.tobytes(), pu.tobytes(), va.tobytes(), p, float(p0))
    try:
        return np.array(_pressure_series(*key))
    except TypeError:  # parameters that cannot be a key (not the frozen Pneumatics): not kept
        return np.array(_pressure_series.__wrapped__(*key))


RUN_CACHE_SIZE = 64  # series of :func:`run_pressure` kept (each a few tens of kB)


def forget_runs() -> None:
    """Empty the cache of :func:`run_pressure` (a benchmark of the simulation itself)."""
    _pressure_series.cache_clear()


@lru_cache(maxsize=RUN_CACHE_SIZE)
def _pressure_series(dt: float, sp: bytes, pu: bytes, va: bytes, p: Pneumatics, p0: float) -> np.ndarray:
    """:func:`run_pressure` of the inputs' bytes (float64 setpoints, bool pump and valve); the
    returned array is read-only (it is shared by every caller of the same inputs)."""
    setpoint_kpa = np.frombuffer(sp, dtype=float).tolist()
    pump = np.frombuffer(pu, dtype=bool).tolist()
    valve = np.frombuffer(va, dtype=bool).tolist()
    out = [0.0] * len(setpoint_kpa)
    pressure = p0
    cache: dict = {}
    limit = p.max_rate_kpa_s * dt
    for k, (s, on, open_) in enumerate(zip(setpoint_kpa, pump, valve)):
        key = (s, on, open_)
        if key not in cache:  # schedules are piecewise constant: few distinct targets
            target, tau = target_and_tau(s, on, open_, p)
            cache[key] = (target, -math.expm1(-dt / tau))
        target, gain = cache[key]
        change = (target - pressure) * gain
        pressure += limit if change > limit else -limit if change < -limit else change
        out[k] = pressure
    series = np.asarray(out)
    series.flags.writeable = False
    return series
