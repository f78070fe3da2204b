"""The emulated board: the firmware's command semantics over a simulated plant.

Mirrors firmware/lib/core/device.cpp rule for rule: duplicate detection on (type, sequence)
with the cached reply resent verbatim (HELLO excepted), NAK codes and details, output
limits, the host-link watchdog, sample ticks from a 1 kHz clock, SAMPLE numbered from 0 in
each stream and ERROR by its own counter, and the model store rules. Times are integers in microseconds: ``T_us`` is emulator
time (the plant's clock, never reset) and the device clock restarts at each boot.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import asdict, dataclass, field

import numpy as np

from porosense.emulator import lines, sensors
from porosense.emulator.model import model_capacity, parse_blob, supported_format_version
from porosense.emulator.store import (
    ConfigStore,
    ModelStore,
    PowerLoss,
    check_config,
    default_config,
)
from porosense.protocol import FrameDecoder, MsgType, Result, encode_frame
from porosense.protocol import _messages as m
from porosense.protocol._messages import VERSION_MAJOR, VERSION_MINOR, Capability, Channel, ConfigKey, StatusFlag

F = StatusFlag
K = ConfigKey
N_CHANNELS = 3
FW_VERSION = (1, 0, 0)
R0_BOOT_SAMPLES = 16
ANALOG_OUT_PIN = 10  # the one PWM pin whose timer the firmware leaves free
FREE_RAM_BYTES = 512  # reported in STATUS; the emulator has no stack to measure
PLANT_MAX_STEP_S = 0.02
RESET_POWER_ON, RESET_EXTERNAL, RESET_WATCHDOG = 0x01, 0x02, 0x08  # AVR MCUSR bits
# Plain ints for the per-sample path (enum arithmetic is slow).
_ADC_FAULT, _IMU_FAULT, _ADC_CLIPPED = int(F.ADC_FAULT), int(F.IMU_FAULT), int(F.ADC_CLIPPED)
_EST_SATURATED = int(F.ESTIMATOR_SATURATED)
_CH_IMU, _CH_ESTIMATES = int(Channel.IMU), int(Channel.ESTIMATES)
_ESTIMATOR_OFF, _OUTPUTS_ACTIVE, _OVERRUN = int(F.ESTIMATOR_OFF), int(F.OUTPUTS_ACTIVE), int(F.OVERRUN)


def _sat16(v: int) -> int:
    return min(v, 0xFFFF)


@dataclass
class BoardStats:
    """What the emulated board did, for tests: commands executed (by type) and duplicates."""

    executed: Counter = field(default_factory=Counter)
    duplicates: int = 0
    samples: int = 0
    boots: int = 0
    reboots_injected: int = 0

    @property
    def executed_total(self) -> int:
        return sum(self.executed.values())

    def to_dict(self) -> dict:
        d = asdict(self)
        d["executed"] = dict(self.executed)
        d["executed_total"] = self.executed_total
        return d


class BoardCore:
    """One emulated board. ``send(frame, sample_t_us)`` carries frames to the link;
    ``tx_room()`` is the free space (bytes) of the transmit path, telemetry is dropped
    when a frame does not fit (like the firmware with its UART buffer)."""

    def __init__(self, plant, *, send, tx_room=lambda: 1 << 30, faults=None, proto_version=None):
        self.plant = plant
        # Ground truth at each sample's device time (us since boot), when asked for:
        # {"t_us": [...], key: [...]}, one list per scalar truth value.
        self.truth_log: dict | None = None
        self._send_raw = send
        self._tx_room = tx_room
        self.faults = faults
        self.proto_version = proto_version or (VERSION_MAJOR, VERSION_MINOR)
        self.model_store = ModelStore(model_capacity(), parse_blob, supported_format_version())
        if faults and faults.reset_after_model_bytes is not None:
            self.model_store.power_fail_after = int(faults.reset_after_model_bytes)
        self.config_store = ConfigStore()
        self.stats = BoardStats()
        self.adc_present = not (faults and faults.adc_disconnect)
        self.imu_present = not (faults and faults.imu_disconnect)
        self._rx_budget = faults.reset_after_rx_bytes if faults else None
        self.T_us = 0
        self._plant_T_us = 0
        self._reading = None
        self._reset_cause = RESET_POWER_ON
        self.boot(0, RESET_POWER_ON)

    # ------------------------------------------------------------------ boot and clock

    def boot(self, T_us: int, cause: int) -> None:
        """Power-on or reset: RAM state lost, EEPROM kept, the plant keeps running."""
        self.stats.boots += 1
        self.T_us = T_us
        self.boot_T_us = T_us
        self._reset_cause = cause
        self.decoder = FrameDecoder()
        self.cached: bytes | None = None
        self.last_type = 0
        self.last_seq = 0
        self.streaming = False
        self.stream_mask = 0
        self.rate_hz = 0
        self._tick_k = 0
        self._stream_T0_us = 0
        self.telemetry_seq = 0
        self.error_seq = 0
        self.sticky = 0
        self.sample_flags = 0
        self.pending_overrun = False
        self.counters = dict.fromkeys(
            ("overruns", "dropped_telemetry", "watchdog_trips", "sensor_faults", "rx_frames", "tx_frames"), 0
        )
        self.setpoint_dkpa = [0, 0, 0]
        self.pump_mask = 0
        self.valve_mask = 0
        self.model_store.reboot()
        saved = self.config_store.load()
        if saved is not None:
            self.config = saved
            self.config_store.boots = _sat16(self.config_store.boots + 1)
        else:
            self.config = default_config()
            self.sticky |= F.CONFIG_DEFAULTS
        self.watchdog_ms = self.config[K.WATCHDOG_MS]
        self.r0_mohm = [self.config[K.R0_CH0_MOHM], self.config[K.R0_CH1_MOHM], self.config[K.R0_CH2_MOHM]]
        self.model = None
        blob = self.model_store.stored_blob()
        self.model_status = 0
        if blob is not None:
            try:
                self.model = parse_blob(blob)
                self.model_status = 1
            except Exception:
                self.model_status = 2
        if not self.adc_present:
            self.sample_flags |= F.ADC_FAULT
        if not self.imu_present:
            self.sample_flags |= F.IMU_FAULT
        r0_stored = self.config[K.R0_MODE] == 1 and not (self.sticky & F.CONFIG_DEFAULTS)
        if not r0_stored:
            self.sticky |= F.R0_UNCALIBRATED  # cleared when a channel gives a usable R0
            self._calibrate_r0(R0_BOOT_SAMPLES, 0x07)
        # CSV line mode of this session (firmware: Device::set_line_mode): off after any frame.
        self.line_mode = bool(self.config[K.LINE_MODE])
        self.line_header = True
        if self.config[K.AUTOSTART] and self.model is not None:
            self._start_stream(self.config[K.SAMPLE_RATE_HZ], self.config[K.CHANNEL_MASK])
            self.sticky |= F.STANDALONE
        self._link_fed_ms = 0

    @property
    def now_us(self) -> int:
        """Device clock (us since boot)."""
        return self.T_us - self.boot_T_us

    @property
    def now_ms(self) -> int:
        return self.now_us // 1000

    def set_time(self, T_us: int) -> None:
        """Advance emulator time to ``T_us`` and run the host-link watchdog."""
        if T_us > self.T_us:
            self.T_us = T_us
        if self.outputs_active and self.now_ms - self._link_fed_ms > self.watchdog_ms:
            self._outputs_off()
            self.sticky |= F.WATCHDOG_TRIPPED
            self.counters["watchdog_trips"] = _sat16(self.counters["watchdog_trips"] + 1)
            self._send_error(Result.BAD_STATE, int(F.WATCHDOG_TRIPPED), self.now_us)

    def power_cycle(self) -> None:
        """Reset now as if the power had been cut (no reply to anything pending)."""
        self.stats.reboots_injected += 1
        self._outputs_off()
        self.boot(self.T_us, RESET_POWER_ON)

    # ------------------------------------------------------------------ plant and sensors

    @property
    def outputs_active(self) -> bool:
        return bool(self.pump_mask or self.valve_mask or any(self.setpoint_dkpa))

    def _outputs_off(self) -> None:
        self._advance_plant()
        self.setpoint_dkpa = [0, 0, 0]
        self.pump_mask = 0
        self.valve_mask = 0

    def _advance_plant(self, T_us: int | None = None, *, min_step_s: float = 0.0) -> None:
        """Step the plant to ``T_us`` with the current outputs (in steps of at most 20 ms)."""
        T_us = self.T_us if T_us is None else T_us
        dt = (T_us - self._plant_T_us) * 1e-6
        if dt <= 0 and self._reading is not None and min_step_s <= 0:
            return
        dt = max(dt, min_step_s, 1e-4)
        n = min(max(1, math.ceil(dt / PLANT_MAX_STEP_S)), 500)
        sp = [v / 10.0 for v in self.setpoint_dkpa]
        pump = [bool(self.pump_mask >> i & 1) for i in range(3)]
        valve = [bool(self.valve_mask >> i & 1) for i in range(3)]
        for _ in range(n):
            self._reading = self.plant.step(dt / n, sp, pump, valve)
        self._plant_T_us = max(self._plant_T_us, T_us)

    def _adc_counts(self) -> list[int]:
        v = np.asarray(self._reading.voltage_V, dtype=float)
        pga = self.config[K.ADC_PGA]
        return [sensors.volts_to_counts(v[ch], pga) if ch < len(v) else 0 for ch in range(3)]

    def _calibrate_r0(self, n_samples: int, mask: int) -> bool:
        if not self.adc_present:
            self.counters["sensor_faults"] = _sat16(self.counters["sensor_faults"] + 1)
            return False
        conversion_s = 3.0 / sensors.ADC_SPS[self.config[K.ADC_RATE]]
        sums = [0, 0, 0]
        for _ in range(n_samples):
            self._advance_plant(self._plant_T_us, min_step_s=conversion_s)
            counts = self._adc_counts()
            for ch in range(3):
                sums[ch] += counts[ch]
        pga = self.config[K.ADC_PGA]
        usable = False
        for ch in range(3):
            if not mask >> ch & 1:
                continue
            ohm = sensors.counts_to_ohm(np.float32(sums[ch]) / np.float32(n_samples), pga)
            mohm = float(ohm) * 1000.0 + 0.5
            spec = m.CONFIG_SPECS[ConfigKey(K.R0_CH0_MOHM + ch)]
            if not spec.min <= mohm <= spec.max:
                continue  # an open (unwired) or shorted input gives no usable R0: keep the old one
            self.r0_mohm[ch] = int(mohm)
            self.config[K.R0_CH0_MOHM + ch] = int(mohm)
            usable = True
        if usable:
            self.sticky &= ~F.R0_UNCALIBRATED
        return True

    # ------------------------------------------------------------------ link

    def _send(self, frame: bytes, sample_t_us: int | None = None) -> None:
        self._send_raw(frame, sample_t_us)
        self.counters["tx_frames"] += 1

    def _reply(self, msg) -> None:
        self.cached = encode_frame(msg.TYPE, self.last_seq, msg.pack(), self._version_byte)
        self._send(self.cached)

    @property
    def _version_byte(self) -> int:
        return (self.proto_version[0] << 4) | self.proto_version[1]

    def _ack(self) -> None:
        self._reply(m.Ack(acked_type=self.last_type))

    def _nak(self, code: int, detail: int = 0) -> None:
        self._reply(m.Nak(acked_type=self.last_type, code=int(code), detail=int(detail)))

    def _send_unsolicited(self, msg, sample_t_us: int | None = None) -> None:
        # SAMPLE and ERROR number themselves with separate counters; a dropped frame still
        # takes its number, so the host sees the gap.
        if msg.TYPE == MsgType.SAMPLE:
            seq, self.telemetry_seq = self.telemetry_seq, (self.telemetry_seq + 1) & 0xFF
        else:
            seq, self.error_seq = self.error_seq, (self.error_seq + 1) & 0xFF
        frame = encode_frame(msg.TYPE, seq, msg.pack(), self._version_byte)
        if self._tx_room() < len(frame):
            self.counters["dropped_telemetry"] = _sat16(self.counters["dropped_telemetry"] + 1)
            return
        self._send(frame, sample_t_us)

    def _send_error(self, code: int, detail: int, t_us: int) -> None:
        self._send_unsolicited(m.Error(code=int(code), detail=int(detail), t_us=t_us & 0xFFFFFFFF))

    def receive(self, data: bytes) -> None:
        """Bytes from the host (after the link's faults); executes complete commands."""
        if self._rx_budget is not None:
            if len(data) >= self._rx_budget:
                data = data[: self._rx_budget]
                self._rx_budget = None
                self._feed(data)
                self.power_cycle()
                return
            self._rx_budget -= len(data)
        self._feed(data)

    def _feed(self, data: bytes) -> None:
        for frame in self.decoder.feed(data):
            self.line_mode = False  # a host speaks frames: this session answers in frames
            self.counters["rx_frames"] += 1
            self._link_fed_ms = self.now_ms
            try:
                self._handle(frame)
            except PowerLoss:
                self.power_cycle()
                return

    def _handle(self, frame) -> None:
        # A retry carries the same sequence number and type: answer it without executing again.
        # HELLO is never a duplicate (a new host session must not collide with the last one).
        if (self.cached is not None and frame.type == self.last_type and frame.seq == self.last_seq
                and frame.type != MsgType.HELLO):
            self.stats.duplicates += 1
            self._send(self.cached)
            return
        self.last_type = frame.type
        self.last_seq = frame.seq
        cls = m.MESSAGES.get(frame.type)
        if cls is None or frame.type & 0x80:
            return self._nak(Result.UNKNOWN_TYPE, 0)
        if not cls.MIN_LEN <= len(frame.payload) <= cls.MAX_LEN:
            return self._nak(Result.BAD_LENGTH, cls.MIN_LEN)
        try:
            msg = cls.unpack(frame.payload)
        except ValueError:
            return self._nak(Result.BAD_LENGTH, cls.MIN_LEN)
        self.stats.executed[MsgType(frame.type).name] += 1
        handler = getattr(self, "_cmd_" + MsgType(frame.type).name.lower(), None)
        if handler is None:
            return self._nak(Result.UNKNOWN_TYPE, 0)
        handler(msg, frame)

    # ------------------------------------------------------------------ commands

    def _cmd_hello(self, msg, frame) -> None:
        self._hello_reply()
        self.cached = None  # HELLO clears the duplicate cache

    def _hello_reply(self) -> None:
        caps = Capability.ESTIMATOR | Capability.EMULATED | Capability.LINE_MODE
        if self.adc_present:
            caps |= Capability.ADC
        if self.imu_present:
            caps |= Capability.IMU
        self._reply(
            m.HelloReply(
                proto_major=self.proto_version[0],
                proto_minor=self.proto_version[1],
                fw_major=FW_VERSION[0],
                fw_minor=FW_VERSION[1],
                fw_patch=FW_VERSION[2],
                capabilities=int(caps),
                n_channels=N_CHANNELS,  # like the firmware: the board has three inputs
                model_status=self.model_status,
                model_crc=self.model_store.header.crc if self.model_store.header.valid else 0,
                streaming=int(self.streaming),
                uptime_ms=self.now_ms & 0xFFFFFFFF,
            )
        )

    def _cmd_ping(self, msg, frame) -> None:
        self._reply(m.Pong(nonce=msg.nonce, device_time_us=self.now_us & 0xFFFFFFFF))

    def _cmd_set_outputs(self, msg, frame) -> None:
        lo = self.config[K.MIN_SETPOINT_DKPA]
        if any(s > 0 or s < lo for s in msg.setpoint_dkpa):
            return self._nak(Result.OUT_OF_RANGE, 0)
        if msg.pump_mask & ~0x07:
            return self._nak(Result.OUT_OF_RANGE, 1)
        if msg.valve_mask & ~0x07:
            return self._nak(Result.OUT_OF_RANGE, 2)
        self._advance_plant()
        self.setpoint_dkpa = list(msg.setpoint_dkpa)
        self.pump_mask = msg.pump_mask
        self.valve_mask = msg.valve_mask
        self.sticky &= ~F.WATCHDOG_TRIPPED
        self._ack()

    def _cmd_set_watchdog(self, msg, frame) -> None:
        if check_config(K.WATCHDOG_MS, msg.timeout_ms) != Result.OK:
            return self._nak(Result.OUT_OF_RANGE, 0)
        self.config[K.WATCHDOG_MS] = msg.timeout_ms
        self.watchdog_ms = msg.timeout_ms
        self._ack()

    def _cmd_start_stream(self, msg, frame) -> None:
        spec = m.CONFIG_SPECS[K.SAMPLE_RATE_HZ]
        if not spec.min <= msg.rate_hz <= spec.max:
            return self._nak(Result.OUT_OF_RANGE, 0)
        if msg.channel_mask & ~0x1F:
            return self._nak(Result.OUT_OF_RANGE, 1)
        self.sticky &= ~F.STANDALONE
        self._start_stream(msg.rate_hz, msg.channel_mask)
        self._ack()

    def _start_stream(self, rate_hz: int, mask: int) -> None:
        if self.model is not None:
            self.model.reset()
        self.stream_mask = mask
        self.rate_hz = rate_hz
        self.telemetry_seq = 0  # each stream numbers its SAMPLE frames from 0
        self.pending_overrun = False
        self.streaming = True
        # The 1 kHz tick runs from the next whole millisecond.
        self._stream_T0_us = self.boot_T_us + (self.now_ms + 1) * 1000
        self._tick_k = 0

    def _cmd_stop_stream(self, msg, frame) -> None:
        self.streaming = False
        self.rate_hz = 0
        self.sticky &= ~F.STANDALONE
        self._ack()

    def _cmd_replay(self, msg, frame) -> None:
        if self.streaming:
            return self._nak(Result.BUSY, 0)
        if self.model is None:
            return self._nak(Result.NO_MODEL, 0)
        values = len(msg.dr_centi)
        if values % 3:
            return self._nak(Result.BAD_LENGTH, 0)
        if msg.reset:
            self.model.reset()
        out, flags = [], 0
        for s in range(0, values, 3):
            est, fl = self.model.step(msg.dr_centi[s : s + 3])
            out.extend(est)
            flags |= fl
        self._reply(m.ReplayResult(flags=flags & 1, estimate=tuple(out)))

    def _cmd_calibrate_r0(self, msg, frame) -> None:
        if not 1 <= msg.n_samples <= 64:
            return self._nak(Result.OUT_OF_RANGE, 0)
        if msg.channel_mask == 0 or msg.channel_mask & ~0x07:
            return self._nak(Result.OUT_OF_RANGE, 1)
        if self.streaming:
            return self._nak(Result.BUSY, 0)
        if not self._calibrate_r0(msg.n_samples, msg.channel_mask):
            return self._nak(Result.SENSOR_FAULT, 0)
        self._reply(m.R0Reply(r0_ohm=tuple(float(np.float32(v) * np.float32(0.001)) for v in self.r0_mohm)))

    def _cmd_set_r0(self, msg, frame) -> None:
        if msg.channel_mask == 0 or msg.channel_mask & ~0x07:
            return self._nak(Result.OUT_OF_RANGE, 0)
        new = list(self.r0_mohm)
        for ch in range(3):
            if not msg.channel_mask >> ch & 1:
                continue
            v = float(np.float32(msg.r0_ohm[ch]) * np.float32(1000.0))
            spec = m.CONFIG_SPECS[ConfigKey(K.R0_CH0_MOHM + ch)]
            if not spec.min <= v <= spec.max:  # NaN fails too
                return self._nak(Result.OUT_OF_RANGE, 1)
            new[ch] = int(v + 0.5)
        self.r0_mohm = new
        for ch in range(3):
            self.config[K.R0_CH0_MOHM + ch] = new[ch]
        self.sticky &= ~F.R0_UNCALIBRATED
        self._ack()

    def flags(self) -> int:
        """Status flags now: sticky ones, the latest sample's sensor flags, and the state."""
        fl = int(self.sticky) | int(self.sample_flags)
        if self.model is None:
            fl |= _ESTIMATOR_OFF
        if self.pump_mask or self.valve_mask or any(self.setpoint_dkpa):
            fl |= _OUTPUTS_ACTIVE
        if self.pending_overrun:
            fl |= _OVERRUN
        return fl

    def _cmd_status(self, msg, frame) -> None:
        d = self.decoder.counters
        c = self.counters
        self._reply(
            m.StatusReply(
                flags=self.flags(),
                bad_crc=_sat16(d["bad_crc"] + d["bad_cobs"]),
                bad_length=_sat16(d["bad_length"] + d["overlong"]),
                bad_version=_sat16(d["bad_version"]),
                unknown_type=_sat16(d["unknown_type"]),
                overruns=c["overruns"],
                dropped_telemetry=c["dropped_telemetry"],
                resets=self.config_store.boots,
                reset_cause=self._reset_cause,
                watchdog_trips=c["watchdog_trips"],
                sensor_faults=c["sensor_faults"],
                free_ram=FREE_RAM_BYTES,
                rx_frames=min(c["rx_frames"], 0xFFFFFFFF),
                tx_frames=min(c["tx_frames"], 0xFFFFFFFF),
                uptime_ms=self.now_ms & 0xFFFFFFFF,
            )
        )

    def _cmd_config_get(self, msg, frame) -> None:
        if msg.key not in self.config:
            return self._nak(Result.BAD_KEY, 0)
        self._reply(m.ConfigValue(key=msg.key, value=self.config[msg.key]))

    def _cmd_config_set(self, msg, frame) -> None:
        # Within the catalogue's limits but outside this board, checked first like the
        # firmware: stored schedules and PWM pins other than D10.
        if (
            (msg.key == K.SCHEDULE_ENABLE and msg.value != 0)
            or (msg.key == K.PWM_PIN and 0 <= msg.value <= 255 and msg.value not in (0, ANALOG_OUT_PIN))
        ):
            return self._nak(Result.UNSUPPORTED, 1)
        code = check_config(msg.key, msg.value)
        if code == Result.BAD_KEY:
            return self._nak(code, 0)
        if code != Result.OK:
            return self._nak(code, 1)
        self.config[msg.key] = msg.value
        if K.R0_CH0_MOHM <= msg.key <= K.R0_CH2_MOHM:
            self.r0_mohm[msg.key - K.R0_CH0_MOHM] = msg.value
            self.sticky &= ~F.R0_UNCALIBRATED
        self.watchdog_ms = self.config[K.WATCHDOG_MS]
        if msg.key == K.LINE_MODE:
            self.line_mode, self.line_header = bool(msg.value), True
        self._ack()

    def _cmd_config_save(self, msg, frame) -> None:
        if self.streaming:
            return self._nak(Result.BUSY, 0)
        self.config_store.save(self.config)
        self.sticky &= ~F.CONFIG_DEFAULTS
        self._ack()

    def _cmd_config_reset(self, msg, frame) -> None:
        if self.streaming:
            return self._nak(Result.BUSY, 0)
        self.config = default_config()
        self.config_store.save(self.config)
        self.watchdog_ms = self.config[K.WATCHDOG_MS]
        self.sticky &= ~F.CONFIG_DEFAULTS
        self._ack()

    def _cmd_reset(self, msg, frame) -> None:
        self._outputs_off()
        self._ack()
        self.boot(self.T_us, RESET_WATCHDOG)

    def _cmd_model_info(self, msg, frame) -> None:
        h = self.model_store.header
        if self.model is not None:
            md = self.model
            reply = m.ModelInfoReply(
                status=1,
                format_version=h.format_version,
                length=h.length,
                crc=h.crc,
                n_inputs=md.n_inputs,
                n_outputs=md.n_outputs,
                model_id=md.model_id,
                out_scale=md.out_scale,
            )
        else:
            reply = m.ModelInfoReply(status=self.model_status)
        self._reply(reply)

    def _cmd_model_read(self, msg, frame) -> None:
        if not 1 <= msg.length <= 112:
            return self._nak(Result.OUT_OF_RANGE, 1)
        code, data = self.model_store.read(msg.offset, msg.length)
        if code != Result.OK:
            return self._nak(code, 0)
        self._reply(m.ModelData(offset=msg.offset, data=data))

    def _model_write(self, op) -> None:
        if self.streaming:
            return self._nak(Result.BUSY, 0)
        code, detail = op()
        if code != Result.OK:
            return self._nak(code, detail)
        self._ack()

    def _cmd_model_begin(self, msg, frame) -> None:
        def op():
            code, detail = self.model_store.begin(msg.length, msg.crc, msg.format_version)
            if code == Result.OK:
                self.model, self.model_status = None, 0
            return code, detail

        self._model_write(op)

    def _cmd_model_chunk(self, msg, frame) -> None:
        self._model_write(lambda: self.model_store.chunk(msg.offset, msg.data))

    def _cmd_model_commit(self, msg, frame) -> None:
        def op():
            code, detail, model = self.model_store.commit()
            if code == Result.OK:
                self.model, self.model_status = model, 1
            return code, detail

        self._model_write(op)

    def _cmd_model_erase(self, msg, frame) -> None:
        def op():
            self.model_store.erase()
            self.model, self.model_status = None, 0
            return Result.OK, 0

        self._model_write(op)

    # ------------------------------------------------------------------ sampling

    def next_tick_T_us(self) -> int | None:
        """Emulator time of the next sample tick (None when not streaming).

        The firmware divides a 1 kHz tick (Bresenham), so sample k falls on millisecond
        ceil(k * 1000 / rate) after the stream started.
        """
        if not self.streaming:
            return None
        k = self._tick_k + 1
        return self._stream_T0_us + -(-k * 1000 // self.rate_hz) * 1000

    def skip_ticks(self, n: int) -> None:
        """``n`` ticks passed without a sample (the loop ran late): overruns."""
        if n > 0:
            self._tick_k += n
            self.counters["overruns"] = _sat16(self.counters["overruns"] + n)
            self.pending_overrun = True

    def sample(self) -> None:
        """Take the sample of the next tick and send its SAMPLE frame."""
        tick_T = self.next_tick_T_us()
        if tick_T is None:
            return
        self._tick_k += 1
        self.set_time(tick_T)
        if not self.streaming:  # the watchdog cannot stop a stream, but stay safe
            return
        self._advance_plant(tick_T)
        mask = self.stream_mask
        t_us = (tick_T - self.boot_T_us) & 0xFFFFFFFF
        if self.truth_log is not None:
            log = self.truth_log
            log.setdefault("t_us", []).append(float(tick_T - self.boot_T_us))
            for k, v in self._reading.truth.items():
                if np.ndim(v) == 0:
                    log.setdefault(k, []).append(float(v))
        adc, dr_out, euler, est = [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]
        estimating = bool(mask & _CH_ESTIMATES) and self.model is not None
        adc_mask = (mask & 0x07) | (0x07 if estimating else 0)
        fl = 0
        dr = [0, 0, 0]
        if adc_mask:
            if not self.adc_present:
                fl |= _ADC_FAULT
            else:
                r0 = [v * 0.001 for v in self.r0_mohm]
                counts, dr, clip = sensors.sample_channels(self._reading.voltage_V, self.config[K.ADC_PGA], r0, adc_mask)
                if clip:
                    fl |= _ADC_CLIPPED
                for ch in range(3):
                    if mask >> ch & 1:
                        adc[ch], dr_out[ch] = counts[ch], dr[ch]
        if mask & _CH_IMU:
            if not self.imu_present:
                fl |= _IMU_FAULT
            else:
                e = self._reading.euler_deg
                euler = [max(-32768, min(32767, round(float(e[i]) * 16.0))) for i in range(3)]
        if estimating and not fl & _ADC_FAULT:
            est, efl = self.model.step(dr)
            if efl & 1:
                fl |= _EST_SATURATED
        faults = _ADC_FAULT | _IMU_FAULT
        new_faults = fl & faults & ~(self.sample_flags & faults)
        if fl & faults:
            self.counters["sensor_faults"] = _sat16(self.counters["sensor_faults"] + 1)
        self.sample_flags = fl
        status = self.flags()
        self.pending_overrun = False
        sample = m.Sample(
            t_us=t_us, channel_mask=mask, status=status, adc=tuple(adc), dr_centi=tuple(dr_out),
            euler_16=tuple(euler), estimate=tuple(est),
        )
        self.stats.samples += 1
        if self.line_mode:
            self._send_line(sample, estimating)
        else:
            self._send_unsolicited(sample, sample_t_us=t_us)
        if new_faults:
            self._send_error(Result.SENSOR_FAULT, int(new_faults), t_us)

    def _send_line(self, sample, estimating: bool) -> None:
        """The CSV line (and the header first) that replaces a SAMPLE in line mode."""
        n_est = self.model.n_outputs if estimating else 0
        scale = self.model.out_scale if self.model is not None else (0.0, 0.0, 0.0)
        text = lines.format_header(sample.channel_mask & 7, n_est) if self.line_header else b""
        text += lines.format_line(sample.t_us // 1000, sample.channel_mask & 7, sample.dr_centi, n_est,
                                  sample.estimate, scale)
        if self._tx_room() < len(text):
            self.counters["dropped_telemetry"] = _sat16(self.counters["dropped_telemetry"] + 1)
            return
        self.line_header = False
        self._send_raw(text, sample.t_us)
