"""Fault injection between the emulated board and its host: a noisy, lossy serial line.

Each byte is corrupted (replaced by a different random value) or dropped with a given
probability, independently per direction. Frames sent by the board are damaged one at a
time, so the link knows exactly which telemetry frames it destroyed: a frame is lost when
any of its bytes, its 0x00 delimiter included, was hit (the host decoder recovers the frame
that follows a damaged delimiter, so damage never spreads to the next frame).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np


@dataclass
class Faults:
    """What can go wrong. Rates are probabilities per byte (0..1).

    rx_*: host -> board; tx_*: board -> host. ``adc_disconnect``/``imu_disconnect`` unplug a
    sensor from boot; ``reset_after_model_bytes`` cuts the power after that many bytes of
    model written to EEPROM; ``reset_after_rx_bytes`` after that many bytes received.
    """

    rx_corrupt: float = 0.0
    rx_drop: float = 0.0
    tx_corrupt: float = 0.0
    tx_drop: float = 0.0
    seed: int = 0
    adc_disconnect: bool = False
    imu_disconnect: bool = False
    reset_after_model_bytes: int | None = None
    reset_after_rx_bytes: int | None = None

    def __post_init__(self):
        for name in ("rx_corrupt", "rx_drop", "tx_corrupt", "tx_drop"):
            rate = getattr(self, name)
            if not 0.0 <= rate <= 1.0:
                raise ValueError(f"{name} must be a probability in 0..1, got {rate}")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class LinkDamage:
    """What the faulty link did: bytes hit per direction and the telemetry frames lost."""

    rx_bytes: int = 0
    rx_corrupted: int = 0
    rx_dropped: int = 0
    tx_bytes: int = 0
    tx_corrupted: int = 0
    tx_dropped: int = 0
    tx_frames_damaged: int = 0
    telemetry_damaged: list[int] = field(default_factory=list)  # board t_us of each lost SAMPLE

    def to_dict(self) -> dict:
        return asdict(self)


class FaultyLink:
    """Applies :class:`Faults` rates to bytes in both directions and records the damage."""

    def __init__(self, faults: Faults):
        self.faults = faults
        self.damage = LinkDamage()
        # One generator per purpose and direction: the decisions for the n-th byte do not
        # depend on how the bytes were split into reads.
        seeds = np.random.SeedSequence(faults.seed).spawn(6)
        self._rng = {
            name: np.random.default_rng(s)
            for name, s in zip(("rx_hit", "rx_drop", "rx_value", "tx_hit", "tx_drop", "tx_value"), seeds)
        }

    def _mangle(self, data: bytes, corrupt: float, drop: float, side: str) -> tuple[bytes, int, int]:
        if not (corrupt or drop) or not data:
            return data, 0, 0
        n = len(data)
        hit_c = self._rng[side + "_hit"].random(n) < corrupt if corrupt else np.zeros(n, bool)
        hit_d = self._rng[side + "_drop"].random(n) < drop if drop else np.zeros(n, bool)
        if not (hit_c.any() or hit_d.any()):
            return data, 0, 0
        buf = np.frombuffer(data, dtype=np.uint8).copy()
        idx = np.flatnonzero(hit_c)
        # XOR with a non-zero value: the byte always changes.
        buf[idx] ^= self._rng[side + "_value"].integers(1, 256, size=len(idx), dtype=np.uint8)
        kept = buf[~hit_d]
        return kept.tobytes(), int(hit_c.sum()), int(hit_d.sum())

    def host_to_board(self, data: bytes) -> bytes:
        """Bytes as the board receives them."""
        out, c, d = self._mangle(data, self.faults.rx_corrupt, self.faults.rx_drop, "rx")
        self.damage.rx_bytes += len(data)
        self.damage.rx_corrupted += c
        self.damage.rx_dropped += d
        return out

    def board_to_host(self, frame: bytes, sample_t_us: int | None = None) -> bytes:
        """One encoded frame as the host receives it; ``sample_t_us`` marks a SAMPLE."""
        out, c, d = self._mangle(frame, self.faults.tx_corrupt, self.faults.tx_drop, "tx")
        self.damage.tx_bytes += len(frame)
        self.damage.tx_corrupted += c
        self.damage.tx_dropped += d
        if c or d:
            self.damage.tx_frames_damaged += 1
            if sample_t_us is not None:
                self.damage.telemetry_damaged.append(sample_t_us)
        return out
