"""Plants for the simboard: the simulator's (porosense.sim) and two small stand-ins.

A plant has ``reset()`` and ``step(dt_s, setpoint_kpa, pump, valve)`` (arrays of 3) returning
an object with ``voltage_V`` (3,), ``euler_deg`` (3,) and ``truth`` (dict), as in
docs/conventions.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BIAS_OHM = 1000.0
SUPPLY_V = 5.0


@dataclass
class Reading:
    """What the board's sensors see after one plant step."""

    voltage_V: np.ndarray
    euler_deg: np.ndarray
    truth: dict = field(default_factory=dict)


class ConstantPlant:
    """Fixed ADC input voltages (V) and Euler angles (deg): for register-level checks."""

    n_channels = 3

    def __init__(self, voltage_V=(1.0, 2.0, 3.0), euler_deg=(0.0, 0.0, 0.0)):
        self.voltage_V = np.asarray(voltage_V, dtype=float)
        self.euler_deg = np.asarray(euler_deg, dtype=float)

    def reset(self) -> None:
        pass

    def step(self, dt_s, setpoint_kpa, pump, valve) -> Reading:
        truth = {
            "setpoint_kpa": np.asarray(setpoint_kpa, float).copy(),
            "pump": np.asarray(pump).copy(),
            "valve": np.asarray(valve).copy(),
        }
        return Reading(self.voltage_V.copy(), self.euler_deg.copy(), truth)


class BringupPlant:
    """A first-order stand-in for the actuator: chamber pressure follows the regulated vacuum
    (time constant ``tau_s``) while pump and valve are on and vents otherwise; resistance
    falls linearly with vacuum (-85 % at -80 kPa); the roll/pitch tilt with channels 0/1."""

    n_channels = 3

    def __init__(self, r0_ohm: float = 2000.0, tau_s: float = 0.3):
        self.r0_ohm = r0_ohm
        self.tau_s = tau_s
        self.reset()

    def reset(self) -> None:
        self.p_kpa = np.zeros(3)

    def step(self, dt_s, setpoint_kpa, pump, valve) -> Reading:
        target = np.where(np.asarray(pump, bool) & np.asarray(valve, bool), np.asarray(setpoint_kpa, float), 0.0)
        self.p_kpa += (target - self.p_kpa) * (1.0 - np.exp(-dt_s / self.tau_s))
        r = self.r0_ohm * (1.0 + 0.85 * self.p_kpa / 80.0)
        v = SUPPLY_V * r / (r + BIAS_OHM)
        euler = np.array([0.0, self.p_kpa[0] / -80.0 * 25.0, self.p_kpa[1] / -80.0 * 22.0])
        truth = {"p": self.p_kpa.copy(), "R": r, "dR": (r - self.r0_ohm) / self.r0_ohm * 100.0}
        return Reading(v, euler, truth)


def default_plant(actuator: str, porosity=None, load_g: float = 0.0, seed: int = 0, effects=None):
    """The simulator's plant for ``actuator``; the bring-up stand-in while porosense.sim is absent."""
    try:
        from porosense.sim import make_plant
    except ImportError:
        return BringupPlant()
    return make_plant(actuator, porosity=porosity, load_g=load_g, seed=seed, effects=effects)
