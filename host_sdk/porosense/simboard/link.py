"""The binary lock-step records exchanged with the simboard harness (tools/simboard/src/cosim.h).

Every period of AVR time the harness writes a 48-byte tick (board state) and waits for a
32-byte reply (sensor inputs and an optional command). All fields are little-endian.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

FREQUENCY_HZ = 16_000_000
TICK_MAGIC = 0x31544253  # "SBT1"
TICK = struct.Struct("<IIQH6BBBHIIIII")
REPLY = struct.Struct("<4f3fBBH")
assert TICK.size == 48 and REPLY.size == 32

# tick events
EV_RESET = 1 << 0
EV_EEPROM_SAVED = 1 << 1
EV_HALTED = 1 << 2
EV_FAULT = 1 << 3
EV_FLASHED = 1 << 4

# reply commands
CMD_NONE = 0
CMD_RESET = 1
CMD_SAVE_EEPROM = 2
CMD_SET_ABSENT = 3
CMD_QUIT = 4
CMD_RESET_AFTER_EE = 5
CMD_POWER_CYCLE = 6
CMD_PROGRAM_FLASH = 7

# Uno pins of the porosense board (firmware/src/pins.h)
PUMP_PINS = (2, 4, 7)
VALVE_PINS = (8, 12, 13)
REGULATOR_PINS = (5, 6, 9)
PWM_PINS = (3, 5, 6, 9, 10, 11)  # order of Tick.duty
FULL_SCALE_KPA = -80.0  # setpoint at 100 % regulator duty
FLASH_PAGE = 128  # bytes per ATmega328P flash page (CMD_PROGRAM_FLASH records)


@dataclass(frozen=True)
class Tick:
    """One board state report from the harness."""

    seq: int
    cycles: int  # AVR cycles since power-on (monotonic across resets)
    pins: int  # bit n: Dn driven high
    duty: tuple[int, ...]  # 0..255 on D3, D5, D6, D9, D10, D11
    events: int
    resets: int
    twi_nacks: int
    uart_rx: int
    uart_tx: int
    eeprom_writes: int
    uart_dropped: int
    adc_conversions: int

    @classmethod
    def unpack(cls, raw: bytes) -> Tick:
        f = TICK.unpack(raw)
        if f[0] != TICK_MAGIC:
            raise ValueError(f"bad tick magic 0x{f[0]:08x}")
        return cls(f[1], f[2], f[3], tuple(f[4:10]), *f[10:])

    @property
    def time_s(self) -> float:
        """AVR time in seconds."""
        return self.cycles / FREQUENCY_HZ


def pack_reply(ain_V, euler_deg, cmd: int = CMD_NONE, arg8: int = 0, arg16: int = 0) -> bytes:
    """The reply to a tick: four ADC input voltages (V), three Euler angles (deg), a command."""
    return REPLY.pack(*(float(v) for v in ain_V), *(float(a) for a in euler_deg), cmd, arg8, arg16)
