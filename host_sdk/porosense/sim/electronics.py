"""Sensor electronics: divider with a bias resistor and the ADS1115.

5.0 V -> bias (1 kOhm) -> ADC node -> sensor -> GND, so ``V = 5 R / (R + bias)`` and
``R = bias V / (5 - V)``. The ADS1115 at PGA +-4.096 V gives 125 uV per count (16-bit signed,
single-ended inputs use 0..32767).
"""

from __future__ import annotations

import numpy as np

from porosense.sim.params import Electronics

ADC_MAX = 32767


def divider_voltage(r_ohm, e: Electronics = Electronics()):
    """ADC node voltage (V) for sensor resistance ``r_ohm``."""
    r = np.asarray(r_ohm, dtype=float)
    return e.supply_V * r / (r + e.bias_ohm)


def resistance_from_voltage(v, e: Electronics = Electronics()):
    """Sensor resistance (ohm) from the node voltage (V); inf at or above the supply."""
    v = np.asarray(v, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(v < e.supply_V, e.bias_ohm * v / np.maximum(e.supply_V - v, 1e-12), np.inf)


def lsb_V(e: Electronics = Electronics()) -> float:
    """Volts per ADC count."""
    return e.pga_fs_V / 32768.0


def adc_counts(v, e: Electronics = Electronics()) -> np.ndarray:
    """ADS1115 counts (int16) for input voltage ``v`` (V), clipped to the PGA range."""
    counts = np.round(np.asarray(v, dtype=float) / lsb_V(e))
    return np.clip(counts, -32768, ADC_MAX).astype(np.int16)


def counts_to_voltage(counts, e: Electronics = Electronics()):
    """Voltage (V) of ADC counts."""
    return np.asarray(counts, dtype=float) * lsb_V(e)
