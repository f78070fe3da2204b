"""Typed answers of the device: handshake, health, model and stream figures.

Each is a small dataclass that prints well and converts to a dict (``to_dict``) for JSON.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from porosense.protocol import StatusFlag
from porosense.protocol._messages import Capability

MODEL_STATUS_NAMES = {0: "none", 1: "valid", 2: "invalid"}


def flag_names(flags: int, enum_type=StatusFlag) -> list[str]:
    """Names of the bits set in ``flags`` (status flags by default)."""
    return [f.name for f in enum_type if flags & f.value]


class _Dictable:
    def to_dict(self) -> dict:
        """Plain-JSON dict of the fields."""
        return asdict(self)


@dataclass(frozen=True)
class HelloInfo(_Dictable):
    """The handshake answer (HELLO_REPLY): protocol and firmware versions, capabilities, model status.

    Attributes
    ----------
    proto_major, proto_minor : int
        The device's protocol version.
    firmware : str
        Firmware version, ``"major.minor.patch"``.
    capabilities : list of str
        Names of the capability bits set (``"EMULATED"``, ...).
    n_channels : int
        Sensor channels the board reads.
    model_status : str
        ``"none"``, ``"valid"`` or ``"invalid"``.
    model_crc : int
        CRC of the stored model blob, 0..0xFFFF.
    streaming : bool
        Whether SAMPLE telemetry was running.
    uptime_ms : int
        Time since the board's reset, ms.
    """

    proto_major: int
    proto_minor: int
    firmware: str
    capabilities: list[str]
    n_channels: int
    model_status: str
    model_crc: int
    streaming: bool
    uptime_ms: int

    @property
    def emulated(self) -> bool:
        """True for the emulator (the firmware core on a host computer)."""
        return "EMULATED" in self.capabilities

    def __str__(self) -> str:
        return (
            f"protocol {self.proto_major}.{self.proto_minor}, firmware {self.firmware}, "
            f"{self.n_channels} channel(s), capabilities {'|'.join(self.capabilities) or '-'}, "
            f"model {self.model_status} (crc 0x{self.model_crc:04X}), up {self.uptime_ms / 1000:.1f} s"
        )

    @classmethod
    def from_message(cls, m) -> HelloInfo:
        """From a decoded HELLO_REPLY.

        Parameters
        ----------
        m : porosense.protocol.HelloReply
            The message.

        Returns
        -------
        HelloInfo
            Versions, capability names and model status by name.
        """
        return cls(
            proto_major=m.proto_major,
            proto_minor=m.proto_minor,
            firmware=f"{m.fw_major}.{m.fw_minor}.{m.fw_patch}",
            capabilities=flag_names(m.capabilities, Capability),
            n_channels=m.n_channels,
            model_status=MODEL_STATUS_NAMES.get(m.model_status, str(m.model_status)),
            model_crc=m.model_crc,
            streaming=bool(m.streaming),
            uptime_ms=m.uptime_ms,
        )


@dataclass(frozen=True)
class PingResult(_Dictable):
    """A PING round trip.

    Attributes
    ----------
    nonce : int
        The value sent and echoed.
    device_time_us : int
        The device clock when it answered, us since its reset.
    rtt_s : float
        Host round-trip time, s.
    """

    nonce: int
    device_time_us: int
    rtt_s: float


@dataclass(frozen=True)
class DeviceStatus(_Dictable):
    """Health counters of STATUS_REPLY (each saturates at its maximum on the device).

    Attributes
    ----------
    flags : int
        Status bits (porosense.protocol.StatusFlag).
    bad_crc, bad_length, bad_version, unknown_type : int
        Received frames dropped, by reason, counts.
    overruns : int
        Sample ticks missed because the previous sample ran late, counts.
    dropped_telemetry : int
        SAMPLE frames not sent because the UART buffer was full, counts.
    resets : int
        Boots since the stored configuration was created, counts.
    reset_cause : int
        MCUSR (the AVR's reset-cause register) of the last reset.
    watchdog_trips : int
        Host-link watchdog trips (outputs switched off), counts.
    sensor_faults : int
        Sensor reads that failed or timed out, counts.
    free_ram : int
        Never-touched stack headroom, bytes.
    rx_frames, tx_frames : int
        Frames received and sent, counts.
    uptime_ms : int
        Time since the board's reset, ms.
    """

    flags: int
    bad_crc: int
    bad_length: int
    bad_version: int
    unknown_type: int
    overruns: int
    dropped_telemetry: int
    resets: int
    reset_cause: int
    watchdog_trips: int
    sensor_faults: int
    free_ram: int
    rx_frames: int
    tx_frames: int
    uptime_ms: int

    @property
    def flag_names(self) -> list[str]:
        return flag_names(self.flags)

    def has(self, flag: StatusFlag) -> bool:
        """Whether a status flag is set.

        Parameters
        ----------
        flag : StatusFlag
            The flag.

        Returns
        -------
        bool
            True when ``flag`` is set.
        """
        return bool(self.flags & flag)

    @property
    def dropped_frames(self) -> int:
        """Received frames the device dropped for any reason (CRC, length, version, type)."""
        return self.bad_crc + self.bad_length + self.bad_version + self.unknown_type

    @classmethod
    def from_message(cls, m) -> DeviceStatus:
        """From a decoded STATUS_REPLY.

        Parameters
        ----------
        m : porosense.protocol.StatusReply
            The message.

        Returns
        -------
        DeviceStatus
            Its counters.
        """
        return cls(**{k: getattr(m, k) for k in cls.__dataclass_fields__})

    def __str__(self) -> str:
        return (
            f"flags {'|'.join(self.flag_names) or '-'}; rx {self.rx_frames} tx {self.tx_frames} frames; "
            f"dropped crc {self.bad_crc} len {self.bad_length} ver {self.bad_version} type {self.unknown_type}; "
            f"overruns {self.overruns}, telemetry dropped {self.dropped_telemetry}, "
            f"watchdog trips {self.watchdog_trips}, sensor faults {self.sensor_faults}, "
            f"free RAM {self.free_ram} B, up {self.uptime_ms / 1000:.1f} s"
        )


@dataclass(frozen=True)
class ModelInfo(_Dictable):
    """The stored model (MODEL_INFO_REPLY).

    Attributes
    ----------
    status : str
        ``"none"``, ``"valid"`` or ``"invalid"``.
    format_version : int
        Blob format version.
    length : int
        Blob length, bytes.
    crc : int
        Blob CRC, 0..0xFFFF.
    n_inputs, n_outputs : int
        The model's inputs and outputs.
    model_id : int
        32-bit id stored in the blob.
    out_scale : tuple of float
        Per output, output units (kPa, deg, % strain) per estimate LSB.
    slot : int
        Running slot: 0, 1 EEPROM; 2, 3 flash store; 255 none.
    seq : int
        The slot's commit counter, modulo 256.
    """

    status: str
    format_version: int
    length: int
    crc: int
    n_inputs: int
    n_outputs: int
    model_id: int
    out_scale: tuple[float, ...]
    slot: int = 0xFF  # running slot: 0, 1 EEPROM; 2, 3 flash store; 255 none
    seq: int = 0  # its commit counter (modulo 256)

    @property
    def valid(self) -> bool:
        return self.status == "valid"

    @property
    def store(self) -> str:
        """Where the running model is stored: "eeprom", "flash" or "none"."""
        return "none" if self.slot == 0xFF or not self.valid else ("eeprom" if self.slot < 2 else "flash")

    @classmethod
    def from_message(cls, m) -> ModelInfo:
        """From a decoded MODEL_INFO_REPLY.

        Parameters
        ----------
        m : porosense.protocol.ModelInfoReply
            The message.

        Returns
        -------
        ModelInfo
            Status by name, out_scale for the model's outputs only.
        """
        return cls(
            status=MODEL_STATUS_NAMES.get(m.status, str(m.status)),
            format_version=m.format_version,
            length=m.length,
            crc=m.crc,
            n_inputs=m.n_inputs,
            n_outputs=m.n_outputs,
            model_id=m.model_id,
            out_scale=tuple(float(s) for s in m.out_scale[: max(m.n_outputs, 0)]),
            slot=m.slot,
            seq=m.seq,
        )

    def __str__(self) -> str:
        if not self.valid:
            return f"model {self.status}"
        return (
            f"model valid: id 0x{self.model_id:08X}, format {self.format_version}, {self.length} bytes, "
            f"crc 0x{self.crc:04X}, {self.n_inputs} in / {self.n_outputs} out, scale {self.out_scale}, "
            f"{self.store} slot {self.slot % 2}, counter {self.seq}"
        )


@dataclass(slots=True)
class Sample:
    """One SAMPLE (or CONTROL_SAMPLE) with its unwrapped device time.

    Attributes
    ----------
    seq : int
        SAMPLE sequence number, 0..255 (gaps count lost frames).
    t_us : int
        Device time, us, unwrapped (monotonic over the stream).
    channel_mask : int
        Channel bits present (ADC0..2, IMU, ESTIMATES; porosense.device.ALL_CHANNELS for all).
    status : int
        Status bits (porosense.protocol.StatusFlag).
    adc : tuple of int
        Per sensor channel, ADS1115 reading, counts.
    dr_centi : tuple of int
        Per sensor channel, dR = (R - R0) / R0, in 0.01 % (LSB).
    euler_16 : tuple of int
        BNO055 heading, roll, pitch, 1/16 deg (LSB).
    estimate : tuple of int
        Per model output, the estimator's output, estimate LSB (times ``ModelInfo.out_scale``).
    target : tuple of float
        While the strain controller runs: slewed target per channel, output units (nan when not
        controlled).
    command_kpa : tuple of float
        While the strain controller runs: regulator setpoint per channel, kPa (<= 0).
    target_lsb : tuple of int or None
        The raw slewed targets of CONTROL_SAMPLE, estimate LSB (None outside control).
    """

    seq: int
    t_us: int
    channel_mask: int
    status: int
    adc: tuple[int, ...]
    dr_centi: tuple[int, ...]
    euler_16: tuple[int, ...]
    estimate: tuple[int, ...]
    # While the strain controller runs (CONTROL_SAMPLE): slewed target (output units, nan on a
    # channel not controlled) and the regulator setpoint it sent (kPa, <= 0).
    target: tuple[float, ...] = (math.nan,) * 3
    command_kpa: tuple[float, ...] = (0.0,) * 3
    target_lsb: tuple[int, ...] | None = None  # the raw slewed targets (estimate LSB) of CONTROL_SAMPLE

    @property
    def t_s(self) -> float:
        """Device time in seconds."""
        return self.t_us * 1e-6

    @property
    def dr_percent(self) -> tuple[float, ...]:
        """dR = (R - R0) / R0 in percent."""
        return tuple(d / 100.0 for d in self.dr_centi)

    @property
    def euler_deg(self) -> tuple[float, ...]:
        """BNO055 heading, roll, pitch in degrees."""
        return tuple(e / 16.0 for e in self.euler_16)


@dataclass
class SampleBlock(_Dictable):
    """A run of samples as arrays (one row per Sample; units as in Sample).

    Attributes
    ----------
    t_us : ndarray, shape (N,)
        Unwrapped device time, us.
    status : ndarray, shape (N,)
        Status bits.
    adc : ndarray, shape (N, 3)
        ADC readings, counts.
    dr_centi : ndarray, shape (N, 3)
        dR, 0.01 % (LSB).
    euler_16 : ndarray, shape (N, 3)
        BNO055 heading, roll, pitch, 1/16 deg.
    estimate : ndarray, shape (N, 3)
        Estimator outputs, estimate LSB.
    lost : int
        SAMPLE frames lost in the run (sequence gaps), counts.
    target : ndarray, shape (N, 3), or None
        Slewed control target, output units, nan where not controlled.
    command_kpa : ndarray, shape (N, 3), or None
        Regulator setpoint, kPa.
    """

    t_us: np.ndarray
    status: np.ndarray
    adc: np.ndarray
    dr_centi: np.ndarray
    euler_16: np.ndarray
    estimate: np.ndarray
    lost: int = 0
    target: np.ndarray | None = None  # (N, 3) output units, nan where not controlled
    command_kpa: np.ndarray | None = None  # (N, 3) kPa

    @classmethod
    def from_samples(cls, samples: list[Sample], lost: int = 0) -> SampleBlock:
        """Stack samples into arrays.

        Parameters
        ----------
        samples : list of Sample
            In arrival order.
        lost : int
            SAMPLE frames lost meanwhile.

        Returns
        -------
        SampleBlock
            One row per sample.
        """

        def col(name, dtype=np.int16):
            return np.array([getattr(s, name) for s in samples], dtype=dtype).reshape(len(samples), 3)

        return cls(
            t_us=np.array([s.t_us for s in samples], dtype=np.int64),
            status=np.array([s.status for s in samples], dtype=np.uint16),
            adc=col("adc"),
            dr_centi=col("dr_centi"),
            euler_16=col("euler_16"),
            estimate=col("estimate"),
            lost=lost,
            target=col("target", float),
            command_kpa=col("command_kpa", float),
        )

    def __len__(self) -> int:
        return len(self.t_us)

    def to_recording(self, *, n_channels: int = 3, imu: bool = False, outputs=(), out_scale=(), meta=None):
        """A porosense.data.Recording with the conventions' columns.

        ``t`` (s) counts from the first sample on the device clock (``t_dev_us`` keeps the raw
        unwrapped timestamps).

        Parameters
        ----------
        n_channels : int
            Sensor channels kept: ``adc_i`` (counts) and ``dR_i`` (%) for each.
        imu : bool
            Add ``theta_x``/``theta_y`` (deg, BNO055 roll and pitch).
        outputs : sequence of str
            Model output names: ``est_<name>`` columns (output units).
        out_scale : sequence of float
            Per output, output units per estimate LSB.
        meta : dict or None
            Facts added to the recording's metadata.

        Returns
        -------
        Recording
            With ``target_<name>`` and ``command_kpa_i`` (kPa) columns when the strain controller ran.
        """
        from porosense.data import Recording

        t_us = self.t_us.astype(np.int64)
        cols: dict[str, np.ndarray] = {"t_dev_us": t_us.astype(float)}
        units = {"t_dev_us": "us"}
        for i in range(n_channels):
            cols[f"adc_{i}"] = self.adc[:, i].astype(float)
            cols[f"dR_{i}"] = self.dr_centi[:, i] / 100.0
            units |= {f"adc_{i}": "counts", f"dR_{i}": "%"}
        if imu:
            cols["theta_x"] = self.euler_16[:, 1] / 16.0
            cols["theta_y"] = self.euler_16[:, 2] / 16.0
            units |= {"theta_x": "deg", "theta_y": "deg"}
        for j, (name, scale) in enumerate(zip(outputs, out_scale)):
            cols[f"est_{name}"] = self.estimate[:, j] * float(scale)
        # While the strain controller ran: its slewed target (output units) and command (kPa).
        if self.target is not None and np.isfinite(self.target).any():
            for j, name in enumerate(outputs):
                cols[f"target_{name}"] = self.target[:, j]
            for i in range(n_channels):
                cols[f"command_kpa_{i}"] = self.command_kpa[:, i]
                units[f"command_kpa_{i}"] = "kPa"
        t = (t_us - t_us[0]) * 1e-6 if len(t_us) else np.zeros(0)
        info = {"source": "device", "samples_lost": int(self.lost)} | dict(meta or {})
        return Recording(t, cols, info, units)

    def to_dict(self) -> dict:
        """The arrays as lists.

        Returns
        -------
        dict
            JSON-ready.
        """
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}


@dataclass
class LinkStats(_Dictable):
    """What the host saw on the link (all counts since the Device was opened).

    Attributes
    ----------
    commands : int
        Commands sent.
    retries : int
        Repeated attempts of a command whose answer was late.
    stale_replies : int
        Answers ignored because they belonged to an earlier attempt or command.
    samples : int
        SAMPLE frames received.
    samples_lost : int
        SAMPLE frames missing from the sequence.
    errors_received : int
        Unsolicited ERROR reports received.
    errors_lost : int
        ERROR reports missing from their sequence.
    decoder : dict of str to int
        The frame decoder's counters (valid frames and drops by reason).
    """

    commands: int = 0
    retries: int = 0
    stale_replies: int = 0
    samples: int = 0
    samples_lost: int = 0
    errors_received: int = 0
    errors_lost: int = 0
    decoder: dict = field(default_factory=dict)

    def __str__(self) -> str:
        dropped = sum(v for k, v in self.decoder.items() if k != "frames")
        return (
            f"{self.commands} commands ({self.retries} retries, {self.stale_replies} stale replies), "
            f"{self.samples} samples received, {self.samples_lost} lost, {dropped} bad frames dropped"
        )
