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
    """Chamber pressure (kPa) for each sample of the actuation series (1-D arrays)."""
    setpoint_kpa = np.asarray(setpoint_kpa, dtype=float).tolist()
    pump = np.asarray(pump, dtype=bool).tolist()
    valve = np.asarray(valve, dtype=bool).tolist()
    out = [0.0] * len(setpoint_kpa)
    pressure = p0
    cache: dict = {}
    limit = p.max_rate_kpa_s * dt
    for k, (sp, pu, va) in enumerate(zip(setpoint_kpa, pump, valve)):
        key = (sp, pu, va)
        if key not in cache:  # schedules are piecewise constant: few distinct targets
            target, tau = target_and_tau(sp, pu, va, p)
            cache[key] = (target, -math.expm1(-dt / tau))
        target, gain = cache[key]
        change = (target - pressure) * gain
        pressure += limit if change > limit else -limit if change < -limit else change
        out[k] = pressure
    return np.asarray(out)
