"""The board's sensor chain in software: ADS1115 counts, divider resistance, dR, BNO055 angles.

Same formulas as the firmware (firmware/lib/core/sensing.cpp): 5.0 V -> 1 kOhm bias -> ADC
node -> sensor -> GND, R = 1000 V / (5 - V), dR in 0.01 % rounded half away from zero and
saturated. The per-sample path (:func:`sample_channels`) uses double precision for speed; the
AVR's float32 can differ by one 0.01 % step near a rounding boundary.
"""

from __future__ import annotations

import numpy as np

SUPPLY_V = np.float32(5.0)
BIAS_OHM = np.float32(1000.0)
PGA_FULL_SCALE_V = (6.144, 4.096, 2.048, 1.024, 0.512, 0.256)
ADC_SPS = (8, 16, 32, 64, 128, 250, 475, 860)  # data-rate codes 0..7


def volts_per_count(pga_code: int) -> np.float32:
    """ADS1115 LSB in volts for a PGA code (0 = +-6.144 V ... 5 = +-0.256 V)."""
    return np.float32(PGA_FULL_SCALE_V[min(max(int(pga_code), 0), 5)]) / np.float32(32768.0)


def volts_to_counts(volts: float, pga_code: int) -> int:
    """Single-ended conversion of ``volts`` (V): rounded, clipped to the int16 code range."""
    lsb = PGA_FULL_SCALE_V[min(max(int(pga_code), 0), 5)] / 32768.0
    return int(min(32767, max(-32768, round(float(volts) / lsb))))


def clipped(counts: int) -> bool:
    """True at the converter's full-scale limit."""
    return counts >= 32767 or counts <= -32768


def divider_resistance(volts) -> np.float32:
    """Sensor resistance (ohm) from the divider voltage; 1e9 when the input sits at the supply."""
    v = np.float32(volts)
    if v <= 0:
        return np.float32(0.0)
    headroom = SUPPLY_V - v
    if headroom <= np.float32(1e-6):
        return np.float32(1e9)
    return BIAS_OHM * v / headroom


def counts_to_ohm(mean_counts: float, pga_code: int) -> np.float32:
    """Resistance (ohm) for a (mean) count."""
    return divider_resistance(np.float32(mean_counts) * volts_per_count(pga_code))


def dr_centi(r_ohm, r0_ohm) -> int:
    """dR = (R - R0) / R0 in 0.01 %, rounded half away from zero, saturated to int16."""
    r0 = np.float32(r0_ohm)
    if not r0 > 0:
        return 0
    d = (np.float32(r_ohm) - r0) / r0 * np.float32(10000.0)
    if d >= 32767:
        return 32767
    if d <= -32768:
        return -32768
    return int(d + np.float32(0.5)) if d >= 0 else int(d - np.float32(0.5))


def counts_to_dr_centi(counts: int, pga_code: int, r0_ohm: float) -> int:
    """The whole chain for one channel: counts -> ohm -> dR in 0.01 %."""
    return dr_centi(counts_to_ohm(counts, pga_code), r0_ohm)


def euler_to_16(deg) -> tuple[int, int, int]:
    """BNO055 Euler registers: degrees in 1/16 degree, int16."""
    return tuple(int(min(32767, max(-32768, round(float(d) * 16.0)))) for d in deg)


_LSB = tuple(fs / 32768.0 for fs in PGA_FULL_SCALE_V)


def sample_channels(volts, pga_code: int, r0_ohm, mask: int) -> tuple[list[int], list[int], bool]:
    """Counts and dR (0.01 %) of the channels in ``mask`` (bits 0..2) and whether any clipped."""
    lsb = _LSB[min(max(int(pga_code), 0), 5)]
    counts, dr, clip = [0, 0, 0], [0, 0, 0], False
    for ch in range(3):
        if not mask >> ch & 1:
            continue
        c = round(float(volts[ch]) / lsb) if ch < len(volts) else 0
        c = 32767 if c > 32767 else (-32768 if c < -32768 else c)
        clip = clip or c >= 32767 or c <= -32768
        v = c * lsb
        if v <= 0.0:
            r = 0.0
        elif 5.0 - v <= 1e-6:
            r = 1e9
        else:
            r = 1000.0 * v / (5.0 - v)
        r0 = r0_ohm[ch]
        d = (r - r0) / r0 * 10000.0 if r0 > 0 else 0.0
        if d >= 32767.0:
            q = 32767
        elif d <= -32768.0:
            q = -32768
        else:
            q = int(d + 0.5) if d >= 0 else int(d - 0.5)
        counts[ch], dr[ch] = c, q
    return counts, dr, clip
