"""One emulated board: the firmware core (C++, porosense.firmware.corelib) over a Python HAL
on the simulator plant.

The HAL only does what the hardware does: it steps the plant with the outputs the firmware
drives, presents the plant's divider voltages and Euler angles to the firmware's ADC and IMU
drivers, keeps the clock, carries bytes and injects faults (unplugged chips, power losses).
Every rule of the device (commands, NAKs, duplicates, watchdog, model store, estimator,
sampling, line mode) runs in the firmware's own code.

Times are integers in microseconds: ``T_us`` is emulator time (the plant's clock, never
reset); the device clock restarts at each boot.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from porosense.firmware.corelib import RESET_POWER_ON, RESET_WATCHDOG, FirmwareCore

PLANT_MAX_STEP_S = 0.02
MODEL_REGION_START = 64  # EEPROM address of the model store (MODEL_FORMAT.md)


@dataclass
class BoardStats:
    """Boots, injected power cuts and samples of the emulated board, for tests."""

    boots: int = 0
    reboots_injected: int = 0
    samples: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


class BoardCore:
    """The firmware core with its plant. ``send(data, sample_t_us)`` carries what the UART
    sends (``sample_t_us`` marks the bytes of a sample tick, its SAMPLE frame first);
    ``tx_room()`` is the free space (bytes) of the transmit path beyond the core.
    ``fw.state`` holds what the firmware drives (outputs, streaming, rate, flags)."""

    def __init__(self, plant, *, send, tx_room=lambda: 1 << 30, faults=None, clock_offset_us: int = 0):
        self.plant = plant
        # Ground truth at each sample's device time (us since boot), when asked for:
        # {"t_us": [...], key: [...]}, one list per scalar truth value.
        self.truth_log: dict | None = None
        self._send, self._tx_room = send, tx_room
        self.stats = BoardStats()
        self.fw = FirmwareCore(refresh=self._refresh)
        self._present = [not (faults and faults.adc_disconnect), not (faults and faults.imu_disconnect)]
        self.fw.set_present(*self._present)
        if faults and faults.reset_after_model_bytes is not None:
            self.fw.fail_after_writes(int(faults.reset_after_model_bytes), MODEL_REGION_START)
        self._rx_budget = faults.reset_after_rx_bytes if faults else None
        self.T_us = self._plant_T_us = 0
        self._reading = None
        self._drive = ((0.0,) * 3, (False,) * 3, (False,) * 3)  # setpoints kPa, pumps, valves
        self.boot(RESET_POWER_ON, clock_offset_us)

    # ------------------------------------------------------------------ power, clock, outputs

    def boot(self, cause: int, clock_offset_us: int = 0) -> None:
        """Power-on or reset: RAM state lost, EEPROM kept, the plant keeps running."""
        self.stats.boots += 1
        self.boot_T_us = self.T_us - int(clock_offset_us)
        if self.truth_log:  # the device clock restarts: truth is logged on the new one
            self.truth_log = {}
        self._advance_plant()
        self.fw.set_inputs(self._reading.voltage_V, self._reading.euler_deg)
        self.fw.boot(cause, clock_offset_us)
        self._collect(self.fw.take())

    def power_cycle(self) -> None:
        """Cut the power now (nothing pending is answered) and boot again."""
        self.stats.reboots_injected += 1
        self.fw.take()  # bytes still in the core's transmit path are lost with it
        self.boot(RESET_POWER_ON)

    @property
    def now_us(self) -> int:
        """Device clock (us since power-on)."""
        return self.T_us - self.boot_T_us

    def set_time(self, T_us: int) -> None:
        """Advance emulator time to ``T_us`` and run the firmware's loop (link watchdog)."""
        self.T_us = max(self.T_us, T_us)
        self.fw.set_time(self.now_us)
        self._collect(self.fw.receive(b"", self._tx_room()))

    @property
    def streaming(self) -> bool:
        return bool(self.fw.state.streaming)

    @property
    def outputs(self) -> tuple[list[int], int, int]:
        """(setpoints in 0.1 kPa, pump mask, valve mask) the firmware drives now."""
        st = self.fw.state
        return list(st.setpoint_dkpa), int(st.pump_mask), int(st.valve_mask)

    @property
    def driving(self) -> bool:
        """True while the board drives the plant (a setpoint, a pump or a valve is on)."""
        setpoints, pumps, valves = self._drive
        return any(setpoints) or any(pumps) or any(valves)

    def _collect(self, data: bytes, sample_t_us: int | None = None) -> None:
        """After firmware ran: follow its outputs, pass on its bytes, honour reset or power loss."""
        st = self.fw.state
        if st.power_lost:
            self.power_cycle()  # what it sent since the loss is lost with it
            return
        drive = (
            tuple(v / 10.0 for v in st.setpoint_dkpa),
            tuple(bool(st.pump_mask >> i & 1) for i in range(3)),
            tuple(bool(st.valve_mask >> i & 1) for i in range(3)),
        )
        if drive != self._drive:
            self._advance_plant()  # up to now with the old outputs
            self._drive = drive
        if data:
            self._send(data, sample_t_us)
        if st.reset_requested:
            self.boot(RESET_WATCHDOG)

    # ------------------------------------------------------------------ sensors (the HAL)

    def plug(self, adc: bool | None = None, imu: bool | None = None) -> None:
        """Connect (True) or disconnect (False) the ADC and/or the IMU; None leaves it."""
        self._present = [p if new is None else bool(new) for p, new in zip(self._present, (adc, imu))]
        self.fw.set_present(*self._present)

    def _advance_plant(self, T_us: int | None = None, *, min_step_s: float = 0.0) -> None:
        """Step the plant to ``T_us`` with the outputs now driven (steps of at most 20 ms)."""
        T_us = self.T_us if T_us is None else T_us
        dt = (T_us - self._plant_T_us) * 1e-6
        if dt <= 0 and self._reading is not None and min_step_s <= 0:
            return
        dt = max(dt, min_step_s, 1e-4)
        n = min(max(1, math.ceil(dt / PLANT_MAX_STEP_S)), 500)
        for _ in range(n):
            self._reading = self.plant.step(dt / n, *self._drive)
        self._plant_T_us = max(self._plant_T_us, T_us)

    def _refresh(self, conversion_us: int) -> None:
        """A conversion no presented input covers (R0 calibration): the plant moves on by one
        conversion per channel."""
        self._advance_plant(self._plant_T_us, min_step_s=3 * conversion_us * 1e-6)
        self.fw.set_inputs(self._reading.voltage_V, self._reading.euler_deg)

    # ------------------------------------------------------------------ link and sampling

    def receive(self, data: bytes) -> None:
        """Bytes from the host (after the link's faults); runs the firmware's main loop."""
        cut = self._rx_budget is not None and len(data) >= self._rx_budget
        if self._rx_budget is not None:
            data, self._rx_budget = (data[: self._rx_budget], None) if cut else (data, self._rx_budget - len(data))
        self.fw.set_time(self.now_us)
        self._collect(self.fw.receive(data, self._tx_room()))
        if cut:
            self.power_cycle()

    def next_tick_T_us(self) -> int | None:
        """Emulator time of the next sample tick (None when not streaming)."""
        t = self.fw.next_tick()
        return None if t is None else self.boot_T_us + t

    def run_until(self, T_us: int, *, max_late_us: int | None = None, before_tick=None) -> None:
        """Advance emulator time to ``T_us`` as a board whose loop kept time would have: every
        sample tick on the way at its own time (the plant follows the outputs tick by tick, so a
        late caller changes nothing the board does), then the clock (the firmware's loop) to
        ``T_us``. Ticks more than ``max_late_us`` behind ``T_us`` are not made: the firmware sees
        them missed at once and counts overruns. ``before_tick(T_us)`` runs before each tick made."""
        due = self.next_tick_T_us()
        while due is not None and due <= T_us:
            if max_late_us is not None and T_us - due > max_late_us:
                self.sample(int(T_us - max_late_us))
            else:
                if before_tick is not None:
                    before_tick(due)
                self.sample()
            due = self.next_tick_T_us()
        self.set_time(T_us)

    def sample(self, T_us: int | None = None) -> None:
        """Run the clock to the next tick (or to ``T_us``, the ticks missed on the way counting
        as overruns) and pass on the sample the firmware makes there."""
        tick_T = self.next_tick_T_us()
        if tick_T is None:
            return
        T = tick_T if T_us is None else max(tick_T, T_us)
        self.T_us = max(self.T_us, T)
        self._advance_plant(T)
        r = self._reading
        ticks, data = self.fw.step(T - self.boot_T_us, r.voltage_V, r.euler_deg, self._tx_room())
        if ticks:
            self.stats.samples += 1
            if self.truth_log is not None:
                self.truth_log.setdefault("t_us", []).append(float(T - self.boot_T_us))
                for k, v in r.truth.items():
                    if np.ndim(v) == 0:
                        self.truth_log.setdefault(k, []).append(float(v))
        self._collect(data, (T - self.boot_T_us) % (1 << 32) if ticks else None)
