"""Shared pieces of the standalone tests: a plant whose resistances swing so the estimates
move, configuring a board over the protocol, and raw capture of the serial line."""

from __future__ import annotations

import time

import numpy as np

HANDSHAKE_S = 15.0  # wall time: the simulation may run slower than real time on a busy host

# Status flags (protocol/messages.toml)
CONFIG_DEFAULTS = 1 << 8
STANDALONE = 1 << 11


class SwingPlant:
    """Sensor resistances swinging +-30 % around 2 kOhm (0.7, 1.1 and 1.9 Hz, one per
    channel), pumps and valves ignored: the estimates move on a board without a host."""

    n_channels = 3

    def __init__(self, r0_ohm: float = 2000.0, depth: float = 0.3):
        self.r0_ohm, self.depth = r0_ohm, depth
        self.freq_hz = np.array([0.7, 1.1, 1.9])
        self.t = 0.0
        self.pumps_seen = 0  # plant steps with any pump on or valve open

    def reset(self) -> None:
        self.t = 0.0

    def step(self, dt_s, setpoint_kpa, pump, valve):
        from porosense.simboard.plants import Reading

        self.t += dt_s
        self.pumps_seen += bool(np.any(np.asarray(pump)) or np.any(np.asarray(valve)))
        r = self.r0_ohm * (1.0 + self.depth * np.sin(2 * np.pi * self.freq_hz * self.t + np.array([0.0, 1.0, 2.0])))
        v = 5.0 * r / (r + 1000.0)
        return Reading(v, np.zeros(3), {"R": r})


def configure(board, blob: bytes | None, settings: dict) -> None:
    """Flash ``blob`` (when given), set and save ``settings``, and leave the link."""
    from porosense.device import Device

    with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
        if blob is not None:
            dev.write_model(blob)
        for key, value in settings.items():
            dev.config_set(key, value)
        dev.config_save()


class RawCapture:
    """A plain socket on the board's UART that only listens (no host protocol)."""

    def __init__(self, url: str):
        import serial

        self.port = serial.serial_for_url(url, timeout=0)
        self.data = bytearray()

    def poll(self, wait_s: float = 0.01) -> bytes:
        time.sleep(wait_s)
        chunk = self.port.read(65536)
        self.data += chunk
        return chunk

    def close(self) -> None:
        self.port.close()
