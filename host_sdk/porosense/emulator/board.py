"""One emulated board: the firmware core (C++, through porosense.emulator.native) over a
Python HAL on the simulator plant.

The HAL only does what the hardware does: it steps the plant with the outputs the firmware
drives, presents the plant's divider voltages and Euler angles to the firmware's ADC and IMU
drivers, keeps the clock, carries bytes, and injects faults (unplugged chips, power losses).
Every rule of the device (commands, NAKs, duplicates, watchdog, model store, estimator,
sampling, line mode) runs in the firmware's own code.

Times are integers in microseconds: ``T_us`` is emulator time (the plant's clock, never
reset); the device clock restarts at each boot.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from porosense.emulator.native import RESET_POWER_ON, RESET_WATCHDOG, FirmwareCore

PLANT_MAX_STEP_S = 0.02
MODEL_REGION_START = 64  # EEPROM address of the model store (MODEL_FORMAT.md)
_WRAP = 1 << 32


@dataclass
class BoardStats:
    """What happened to the emulated board, for tests: boots, injected power cuts, samples,
    and the firmware's own frame counters."""

    boots: int = 0
    reboots_injected: int = 0
    samples: int = 0
    rx_frames: int = 0
    tx_frames: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


class BoardCore:
    """The firmware core with its plant. ``send(data, sample_t_us)`` carries what the UART
    sends (``sample_t_us`` marks the bytes of one sample tick, SAMPLE frame first);
    ``tx_room()`` is the free space (bytes) of the transmit path beyond the core."""

    def __init__(self, plant, *, send, tx_room=lambda: 1 << 30, faults=None, clock_offset_us: int = 0):
        self.plant = plant
        # Ground truth at each sample's device time (us since boot), when asked for:
        # {"t_us": [...], key: [...]}, one list per scalar truth value.
        self.truth_log: dict | None = None
        self._send = send
        self._tx_room = tx_room
        self.faults = faults
        self.stats = BoardStats()
        self.fw = FirmwareCore(refresh=self._refresh)
        self._adc_present = not (faults and faults.adc_disconnect)
        self._imu_present = not (faults and faults.imu_disconnect)
        self.fw.set_present(self._adc_present, self._imu_present)
        if faults and faults.reset_after_model_bytes is not None:
            self.fw.fail_after_writes(int(faults.reset_after_model_bytes), MODEL_REGION_START)
        self._rx_budget = faults.reset_after_rx_bytes if faults else None
        self.T_us = 0
        self._plant_T_us = 0
        self._reading = None
        self._outputs = ([0.0, 0.0, 0.0], [False] * 3, [False] * 3)
        self._streaming = False
        self.boot(RESET_POWER_ON, clock_offset_us)

    # ------------------------------------------------------------------ power and clock

    def boot(self, cause: int, clock_offset_us: int = 0) -> None:
        """Power-on or reset: RAM state lost, EEPROM kept, the plant keeps running."""
        self.stats.boots += 1
        self.boot_T_us = self.T_us - int(clock_offset_us)
        self._advance_plant()
        self._push_inputs()
        self.fw.boot(cause, clock_offset_us)
        self._after_call()

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
        """Advance emulator time to ``T_us`` and let the firmware run its link watchdog."""
        if T_us > self.T_us:
            self.T_us = T_us
        self.fw.set_time(self.now_us)
        self.fw.poll()
        self._after_call()

    # ------------------------------------------------------------------ what the firmware drives

    @property
    def setpoint_dkpa(self) -> list[int]:
        return list(self.fw.state().setpoint_dkpa)

    @property
    def pump_mask(self) -> int:
        return int(self.fw.state().pump_mask)

    @property
    def valve_mask(self) -> int:
        return int(self.fw.state().valve_mask)

    @property
    def outputs_active(self) -> bool:
        st = self.fw.state()
        return bool(st.pump_mask or st.valve_mask or any(st.setpoint_dkpa))

    @property
    def streaming(self) -> bool:
        return self._streaming

    @property
    def rate_hz(self) -> int:
        return int(self.fw.state().rate_hz)

    @property
    def analog_out(self) -> tuple[int, int]:
        """(pin, duty 0..255) of the analogue estimate output last driven."""
        st = self.fw.state()
        return int(st.analog_pin), int(st.analog_duty)

    def eeprom(self) -> bytes:
        return self.fw.eeprom()

    # ------------------------------------------------------------------ sensors (the HAL)

    @property
    def adc_present(self) -> bool:
        return self._adc_present

    @adc_present.setter
    def adc_present(self, present: bool) -> None:
        self._adc_present = bool(present)
        self.fw.set_present(self._adc_present, self._imu_present)

    @property
    def imu_present(self) -> bool:
        return self._imu_present

    @imu_present.setter
    def imu_present(self, present: bool) -> None:
        self._imu_present = bool(present)
        self.fw.set_present(self._adc_present, self._imu_present)

    def _advance_plant(self, T_us: int | None = None, *, min_step_s: float = 0.0) -> None:
        """Step the plant to ``T_us`` with the outputs now driven (steps of at most 20 ms)."""
        T_us = self.T_us if T_us is None else T_us
        dt = (T_us - self._plant_T_us) * 1e-6
        if dt <= 0 and self._reading is not None and min_step_s <= 0:
            return
        dt = max(dt, min_step_s, 1e-4)
        n = min(max(1, math.ceil(dt / PLANT_MAX_STEP_S)), 500)
        sp, pump, valve = self._outputs
        for _ in range(n):
            self._reading = self.plant.step(dt / n, sp, pump, valve)
        self._plant_T_us = max(self._plant_T_us, T_us)

    def _push_inputs(self) -> None:
        r = self._reading
        self.fw.set_inputs(r.voltage_V, r.euler_deg)

    def _refresh(self, conversion_us: int) -> None:
        """A conversion no pushed input covers (R0 calibration): the plant moves on by the
        time of one conversion per channel."""
        self._advance_plant(self._plant_T_us, min_step_s=3 * conversion_us * 1e-6)
        self._push_inputs()

    def _after_call(self, sample_t_us: int | None = None) -> None:
        """Collect what the firmware did: bytes sent, outputs driven, a reset or power loss."""
        data = self.fw.take()
        st = self.fw.state()
        self._streaming = bool(st.streaming)
        self.stats.rx_frames, self.stats.tx_frames = int(st.rx_frames), int(st.tx_frames)
        sp = [v / 10.0 for v in st.setpoint_dkpa]
        pump = [bool(st.pump_mask >> i & 1) for i in range(3)]
        valve = [bool(st.valve_mask >> i & 1) for i in range(3)]
        if (sp, pump, valve) != self._outputs:
            self._outputs = (sp, pump, valve)
        if st.power_lost:
            self.power_cycle()  # what it sent before the loss is lost with it
            return
        if data:
            self._send(data, sample_t_us)
        if st.reset_requested:
            self.fw.take()
            self.boot(RESET_WATCHDOG)

    # ------------------------------------------------------------------ link

    def receive(self, data: bytes) -> None:
        """Bytes from the host (after the link's faults); runs the firmware's main loop."""
        if self._rx_budget is not None:
            if len(data) >= self._rx_budget:
                data, self._rx_budget = data[: self._rx_budget], None
                self._receive(data)
                self.power_cycle()
                return
            self._rx_budget -= len(data)
        self._receive(data)

    def _receive(self, data: bytes) -> None:
        self.fw.set_tx_room(self._tx_room())
        self.fw.set_time(self.now_us)
        self.fw.feed(data)
        self._advance_plant()  # outputs change now: the plant has run with the old ones
        self.fw.poll()
        self._after_call()

    # ------------------------------------------------------------------ sampling

    def next_tick_T_us(self) -> int | None:
        """Emulator time of the next sample tick (None when not streaming)."""
        t = self.fw.next_tick()
        return None if t is None else self.boot_T_us + t

    def sample(self, T_us: int | None = None) -> None:
        """Run the clock to the next tick (or to ``T_us``, counting the ticks missed on the
        way as overruns) and take the sample the firmware makes there."""
        tick_T = self.next_tick_T_us()
        if tick_T is None:
            return
        T = max(tick_T, T_us) if T_us is not None else tick_T
        self.T_us = max(self.T_us, T)
        self._advance_plant(T)
        self._push_inputs()
        self.fw.set_tx_room(self._tx_room())
        t_dev = T - self.boot_T_us
        if not self.fw.run_to(t_dev):
            return
        self.stats.samples += 1
        if self.truth_log is not None:
            log = self.truth_log
            log.setdefault("t_us", []).append(float(t_dev))
            for k, v in self._reading.truth.items():
                if np.ndim(v) == 0:
                    log.setdefault(k, []).append(float(v))
        self._after_call(sample_t_us=t_dev % _WRAP)
        self.fw.poll()  # commands that arrived during the sample, the link watchdog
        self._after_call()
