"""Strain-control gains and trajectories in the board's fixed point (protocol CONTROL_GAINS,
TRAJECTORY_CHUNK; firmware/lib/core/control.h).

The board's PI works per estimate LSB and per sample; these functions convert gains given in
the model's output units (kPa per unit of error, kPa per unit-second, units per second) for
one model (its ``out_scale``) and one sample rate, and back. Trajectories become the
CRC-checked record the board stores.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from porosense.errors import InputError
from porosense.protocol import crc16

CHANNELS = 3
TARGET_LIMIT_LSB = 30000  # the estimator's design output range (MODEL_FORMAT.md)
MAX_KP_Q16 = 32767
U16 = 65535
TRAJ_TICK_S = 0.01  # a trajectory's time unit
TRAJ_MAX_SEGMENT_TICKS = 32767
TRAJ_MAX_RECORD = 56  # bytes of one EEPROM trajectory slot (control_store.h)
TRAJ_REPEAT = 0x80


@dataclass(frozen=True)
class ControlGains:
    """PI gains of one channel in the model's output units (e.g. % strain) and kPa.

    Attributes
    ----------
    kp_kpa : float
        kPa of vacuum command per output unit of estimate error, >= 0.
    ki_kpa_per_s : float
        kPa of vacuum command per (output unit * s) of integrated error, >= 0.
    slew_per_s : float
        Target slew limit, output units per s, > 0 (inf: none).

    Raises
    ------
    InputError
        A gain that is not a number, negative or infinite, or a slew limit <= 0.
    """

    kp_kpa: float
    ki_kpa_per_s: float
    slew_per_s: float

    def __post_init__(self):
        for name in ("kp_kpa", "ki_kpa_per_s", "slew_per_s"):
            v = getattr(self, name)
            if (
                not isinstance(v, (int, float, np.floating, np.integer))
                or math.isnan(float(v))
                or (name != "slew_per_s" and not math.isfinite(float(v)))
            ):
                raise InputError(f"control gain {name} must be a finite number, got {v!r}")
        if self.kp_kpa < 0 or self.ki_kpa_per_s < 0:
            raise InputError(f"control gains must be >= 0 (kp {self.kp_kpa}, ki {self.ki_kpa_per_s})")
        if self.slew_per_s <= 0:
            raise InputError(f"the slew limit must be > 0 units/s, got {self.slew_per_s}")


def per_channel(gains: ControlGains | Sequence[ControlGains]) -> tuple[ControlGains, ...]:
    """One ControlGains per channel (a single one applies to all)."""
    if isinstance(gains, ControlGains):
        return (gains,) * CHANNELS
    gains = tuple(gains)
    if not 1 <= len(gains) <= CHANNELS or not all(isinstance(g, ControlGains) for g in gains):
        raise InputError(f"give one ControlGains or one per channel (1..{CHANNELS}), got {len(gains)}")
    return gains + (gains[-1],) * (CHANNELS - len(gains))


def to_fixed(gains, out_scale: Sequence[float], rate_hz: float) -> dict[str, tuple[int, ...]]:
    """CONTROL_GAINS fields (kp_q16, ki_q22, slew_q4) for ``out_scale`` (output unit per LSB,
    per model output) at ``rate_hz``; channels beyond the model's outputs get zero gains.
    Gains that the fixed point cannot hold raise InputError naming the limit."""
    ts = 1.0 / float(rate_hz)
    kp, ki, sl = [], [], []
    for ch, g in enumerate(per_channel(gains)):
        if ch >= len(out_scale) or not out_scale[ch] > 0:
            kp.append(0), ki.append(0), sl.append(U16)
            continue
        s = float(out_scale[ch])
        k = round(g.kp_kpa * 10 * s * 65536)  # kPa/unit -> dkPa/LSB, Q16
        i = round(g.ki_kpa_per_s * 10 * s * ts * 2**22)  # dkPa/LSB/sample, Q22
        w = max(1, min(U16, round(g.slew_per_s / s * ts * 16)))  # LSB/sample, Q4
        if k > MAX_KP_Q16:
            raise InputError(
                f"kp {g.kp_kpa:g} kPa/unit on channel {ch} exceeds the board's limit "
                f"{MAX_KP_Q16 / (10 * s * 65536):.4g} kPa/unit for this model"
            )
        if i > U16:
            raise InputError(
                f"ki {g.ki_kpa_per_s:g} kPa/(unit s) on channel {ch} exceeds the board's limit "
                f"{U16 / (10 * s * ts * 2**22):.4g} at {rate_hz:g} Hz"
            )
        kp.append(k), ki.append(i), sl.append(w)
    return {"kp_q16": tuple(kp), "ki_q22": tuple(ki), "slew_q4": tuple(sl)}


def from_fixed(kp_q16, ki_q22, slew_q4, out_scale: Sequence[float], rate_hz: float) -> tuple[ControlGains, ...]:
    """The gains in output units that the board's fixed-point values stand for (channels
    without a model output, or gains never set (rate 0), read as zero gains with no slew
    limit: infinity)."""
    out = []
    for ch in range(CHANNELS):
        s = float(out_scale[ch]) if ch < len(out_scale) and out_scale[ch] > 0 else float("nan")
        if not rate_hz or not math.isfinite(s):
            out.append(ControlGains(0.0, 0.0, float("inf")))
            continue
        ts = 1.0 / float(rate_hz)
        out.append(
            ControlGains(kp_q16[ch] / (10 * s * 65536), ki_q22[ch] / (10 * s * ts * 2**22), slew_q4[ch] * s / (ts * 16))
        )
    return tuple(out)


def to_lsb(values, out_scale: Sequence[float], channels: int) -> tuple[int, ...]:
    """Targets in output units -> estimate LSB (int16) per channel; channels outside the mask 0."""
    v = np.atleast_1d(np.asarray(values, dtype=float))
    if v.size == 1:
        v = np.repeat(v, CHANNELS)
    if v.size > CHANNELS:
        raise InputError(f"at most {CHANNELS} targets, got {v.size}")
    v = np.pad(v, (0, CHANNELS - v.size))
    out = []
    for ch in range(CHANNELS):
        if not channels >> ch & 1:
            out.append(0)
            continue
        if not math.isfinite(v[ch]):
            raise InputError(f"target of channel {ch} is not a number")
        s = out_scale[ch] if ch < len(out_scale) and out_scale[ch] > 0 else out_scale[0]
        out.append(int(np.clip(round(v[ch] / s), -32768, 32767)))  # the board checks the range
    return tuple(out)


def trajectory_record(t_s, targets, out_scale: Sequence[float], *, repeat: bool = False) -> bytes:
    """The board's trajectory record for piecewise-linear ``targets`` at times ``t_s``.

    ``t_s`` (n,) from 0, increasing (s, 10 ms resolution, at most 327.67 s between points);
    ``targets`` (n,) for every controlled channel or (n, 3) per channel, in output units.
    At most 13 points of one column or 6 of three (the EEPROM slot holds 56 bytes)."""
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(targets, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise InputError("a trajectory needs at least 2 times (s)")
    if y.shape not in ((len(t),), (len(t), 3)):
        raise InputError(f"trajectory targets must have shape ({len(t)},) or ({len(t)}, 3), got {y.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise InputError("trajectory times and targets must be finite numbers")
    ticks = np.round(t / TRAJ_TICK_S).astype(np.int64)
    if ticks[0] != 0:
        raise InputError(f"a trajectory starts at t = 0 s, got {t[0]:g} s")
    d = np.diff(ticks)
    if np.any(d <= 0) or np.any(d > TRAJ_MAX_SEGMENT_TICKS) or ticks[-1] > U16:
        raise InputError("trajectory times must increase by 0.01 .. 327.67 s and end by 655.35 s")
    cols = 1 if y.ndim == 1 else 3
    size = 2 + len(t) * (2 + 2 * cols) + 2
    if size > TRAJ_MAX_RECORD:
        most = (TRAJ_MAX_RECORD - 4) // (2 + 2 * cols)
        raise InputError(f"the board stores at most {most} points of {cols} column(s); got {len(t)}")
    y2 = y.reshape(len(t), cols)
    lsb = np.zeros_like(y2, dtype=np.int64)
    for c in range(cols):
        s = out_scale[c] if c < len(out_scale) and out_scale[c] > 0 else out_scale[0]
        lsb[:, c] = np.round(y2[:, c] / s)
    if np.any(np.abs(lsb) > TARGET_LIMIT_LSB):
        raise InputError(
            "a trajectory target lies outside what the model can estimate "
            f"(+-{TARGET_LIMIT_LSB} LSB, +-{TARGET_LIMIT_LSB * out_scale[0]:.4g} units)"
        )
    body = bytearray((len(t), cols | (TRAJ_REPEAT if repeat else 0)))
    for k in range(len(t)):
        body += struct.pack(f"<H{cols}h", int(ticks[k]), *(int(v) for v in lsb[k]))
    return bytes(body) + struct.pack("<H", crc16(bytes(body)))
