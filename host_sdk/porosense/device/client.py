"""The Device client: commands with deadlines and retries, and the SAMPLE stream.

One command is outstanding at a time. A command is sent with the next sequence number and
retried with the *same* number when its answer does not arrive in time; the device answers a
duplicate from its reply cache without executing it again. An answer is accepted only when
its sequence number and type match the command (ACK/NAK also name the command's type), so a
late answer to an earlier attempt or command is ignored. SAMPLE frames that arrive meanwhile
are queued for :meth:`Device.samples`; gaps in their sequence numbers count lost frames.
"""

from __future__ import annotations

import collections
import math
import random
import struct
import time
from collections.abc import Iterator, Sequence

import numpy as np

from porosense.device import control
from porosense.device.link import SerialLink
from porosense.device.results import (
    DeviceStatus,
    HelloInfo,
    LinkStats,
    ModelInfo,
    PingResult,
    Sample,
    SampleBlock,
)
from porosense.errors import DeviceError, ModelError
from porosense.protocol import (
    MESSAGES,
    FrameDecoder,
    MsgType,
    Result,
    check_compatible,
    encode_frame,
    encode_message,
    split_version,
)
from porosense.protocol import _messages as m
from porosense.protocol._messages import VERSION_BYTE, ConfigKey
from porosense.protocol.model_blob import ModelBlob
from porosense.protocol.model_blob import blob_crc as crc
from porosense.protocol.model_layout import FLASH_BLOB_MAX

DEFAULT_BAUD = 115200
MODEL_CHUNK_BYTES = 112
REPLAY_SAMPLES = 16
TRAJECTORY_CHUNK_BYTES = 48
ALL_CHANNELS = 0x1F

# Host reply timeout = the command's deadline (DEADLINE_MS of the catalogue: 50 ms, 1000 ms
# for EEPROM writes and CALIBRATE_R0) + both frames on the wire + USB-serial latency and an
# interleaved SAMPLE (protocol/spec.md section 7).
_LATENCY_S = 0.025
_MAX_QUEUE_WAIT_S = 0.5  # cap on the extra wait for telemetry queued ahead of an answer
_SAMPLE_WIRE_BYTES = m.Sample.MIN_LEN + 8  # header, CRC, COBS byte, delimiter
_HELLO_REPEAT_S = 0.25  # while waiting for a booting board


def _reply_type(cmd_type: int) -> int:
    return int(MsgType[MESSAGES[cmd_type].REPLY])


def _max_frame_bytes(msg_type: int) -> int:
    """Longest encoded frame of ``msg_type`` (header, CRC, COBS overhead, delimiter)."""
    return MESSAGES[msg_type].MAX_LEN + 4 + 2 + 2 + 1


class NakError(DeviceError):
    """The device refused a command (a NAK; a DeviceError: exit 3).

    Parameters
    ----------
    command : int
        Type id of the refused command; kept as ``command`` (a MsgType when known).
    code : int
        Result code of the NAK; kept as ``code`` (a porosense.protocol.Result when known).
    detail : int
        The NAK's detail byte (which field or limit, per protocol/spec.md); kept as ``detail``.
    """

    def __init__(self, command: int, code: int, detail: int):
        self.command = MsgType(command) if command in MsgType._value2member_map_ else command
        self.code = Result(code) if code in Result._value2member_map_ else code
        self.detail = detail
        cmd = getattr(self.command, "name", f"0x{command:02X}")
        code_name = getattr(self.code, "name", str(code))
        super().__init__(f"device refused {cmd}: {code_name} (detail {detail})")


class Device:
    """A porosense board (real, simboard or emulator) behind a pyserial URL.

    Use :meth:`open` as a context manager::

        with Device.open("socket://127.0.0.1:5000") as dev:
            print(dev.hello())
            dev.start_stream(100)
            for s in dev.samples(200): ...

    Parameters
    ----------
    link : SerialLink
        An open link (``Device.open`` makes one from a pyserial URL).
    baudrate : int
        Line rate, bit/s; sets the wire time added to each command's reply timeout.
    timeout_scale : float
        Factor on every reply timeout (> 1 for a slow link or a loaded host).
    retries : int
        Extra attempts of a command whose answer does not arrive in time.
    seed : int or None
        Seed of the first sequence number (random by default).
    """

    def __init__(
        self,
        link: SerialLink,
        *,
        baudrate: int = DEFAULT_BAUD,
        timeout_scale: float = 1.0,
        retries: int = 3,
        seed: int | None = None,
    ):
        self.link = link
        self.url = link.url
        self.baudrate = baudrate
        self.timeout_scale = float(timeout_scale)
        self.retries = int(retries)
        self.stats = LinkStats()
        self.errors: list[m.Error] = []  # unsolicited ERROR reports, oldest first
        self.info: HelloInfo | None = None
        self._decoder = FrameDecoder()
        self.stats.decoder = self._decoder.counters  # live view
        self._seq = random.Random(seed).randrange(256)
        self._samples: collections.deque[Sample] = collections.deque()
        self._next_tseq: int | None = None  # next SAMPLE sequence number expected
        self._next_eseq: int | None = None  # next ERROR sequence number expected
        self._t_last_raw: int | None = None
        self._t_wraps = 0
        self._rate_hz = 0
        self._streaming = False
        self._outputs_active = False
        # SET_OUTPUTS carries the session of the latest HELLO_REPLY and a counter, so that the
        # device refuses a replayed old frame that would turn outputs on.
        self._session = 0
        self._out_counter = 0
        self._replay_flags: list[int] = []
        # Strain control: the model's out_scale for CONTROL_SAMPLE targets, the gains the host
        # set in output units and the (model CRC, rate) they were last sent to the board for.
        self._out_scale: tuple[float, ...] | None = None
        self._gains = None
        self._gains_for: tuple[int, int] | None = None

    # ------------------------------------------------------------------ opening

    @classmethod
    def open(
        cls,
        url: str,
        *,
        baudrate: int = DEFAULT_BAUD,
        timeout_scale: float = 1.0,
        retries: int = 3,
        handshake: bool = True,
        handshake_timeout_s: float | None = None,
        seed: int | None = None,
    ) -> Device:
        """Open ``url`` and (by default) handshake with HELLO.

        A real Uno resets when its port opens and boots for about 1.5 s, so the handshake is
        retried for ``handshake_timeout_s``.

        Parameters
        ----------
        url : str
            Any pyserial URL: a device path (``/dev/ttyACM0``, ``COM3``), ``socket://host:port``,
            ``loop://``.
        baudrate : int
            Line rate, bit/s.
        timeout_scale : float
            Factor on every reply timeout.
        retries : int
            Extra attempts of a command whose answer does not arrive in time.
        handshake : bool
            Send HELLO and check the protocol version.
        handshake_timeout_s : float or None
            How long to wait for the board to answer HELLO, s (None: 3 s for device paths, 1 s for
            URLs with ``://``).
        seed : int or None
            Seed of the first sequence number.

        Returns
        -------
        Device
            The open device; use it as a context manager to close it.

        Raises
        ------
        DeviceError
            The port cannot be opened, nothing answers, or the protocol major version differs
            (ProtocolVersionError).
        """
        link = SerialLink.open(url, baudrate)
        dev = cls(link, baudrate=baudrate, timeout_scale=timeout_scale, retries=retries, seed=seed)
        if handshake:
            if handshake_timeout_s is None:
                handshake_timeout_s = 1.0 if "://" in url else 3.0
            try:
                link.discard_input()
                dev.hello(wait_s=handshake_timeout_s)
            except BaseException:
                link.close()
                raise
        return dev

    def __enter__(self) -> Device:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop streaming and switch the outputs off (best effort), then close the link."""
        try:
            if self._streaming:
                self.stop_stream()
            if self._outputs_active:
                self.set_outputs()
        except DeviceError:
            pass
        self.link.close()

    # ------------------------------------------------------------------ commands

    def hello(self, wait_s: float | None = None) -> HelloInfo:
        """Handshake: versions, capabilities, model status; starts a new output session.

        Parameters
        ----------
        wait_s : float or None
            Repeat HELLO every 250 ms for up to this long, s (a booting board); None: the usual
            retries.

        Returns
        -------
        HelloInfo
            The answer, also kept as ``self.info``.

        Raises
        ------
        ProtocolVersionError
            The device speaks another protocol major (a DeviceError naming both versions).
        DeviceError
            No answer or a malformed one.
        """
        frame = self._exchange(m.Hello(), wait_total_s=wait_s, raw=True)
        # The header's version byte is checked first: another major may lay HELLO_REPLY out differently.
        check_compatible(*split_version(frame.version))
        try:
            reply = frame.message()
        except ValueError as exc:
            raise DeviceError(f"malformed HELLO_REPLY from {self.url}: {exc}") from None
        check_compatible(reply.proto_major, reply.proto_minor)
        self._session, self._out_counter = reply.session, 0
        self.info = HelloInfo.from_message(reply)
        return self.info

    def ping(self, nonce: int | None = None) -> PingResult:
        """PING: the device clock and the round-trip time; feeds the host-link watchdog.

        Parameters
        ----------
        nonce : int or None
            32-bit value echoed by the device (None: random).

        Returns
        -------
        PingResult
            Device time (us) and round-trip time (s).

        Raises
        ------
        DeviceError
            No answer, or a PONG with another nonce.
        """
        nonce = random.getrandbits(32) if nonce is None else nonce & 0xFFFFFFFF
        t0 = time.perf_counter()
        reply = self._exchange(m.Ping(nonce=nonce))
        rtt = time.perf_counter() - t0
        if reply.nonce != nonce:
            raise DeviceError(f"PONG carries nonce {reply.nonce}, expected {nonce}")
        return PingResult(nonce, reply.device_time_us, rtt)

    def set_outputs(self, setpoint_kpa=0.0, pumps=0, valves=0) -> None:
        """Vacuum setpoints, pumps and valves of the three channels.

        While any output is active the host-link watchdog is armed: send a command (e.g. ping) at
        least every WATCHDOG_MS (1000 ms by default) or the device cuts the outputs. The default
        (all zero) switches everything off.

        Parameters
        ----------
        setpoint_kpa : float or sequence of float
            Gauge vacuum setpoint, kPa (<= 0), one for all channels or one per channel; sent in
            0.1 kPa steps.
        pumps, valves : int or sequence of bool
            Bit masks (bit i = channel i) or one boolean per channel.

        Raises
        ------
        NakError
            A setpoint beyond the board's limit or an output command the board refuses.
        """
        sp = np.atleast_1d(np.asarray(setpoint_kpa, dtype=float))
        sp = np.repeat(sp, 3) if sp.size == 1 else np.pad(sp, (0, 3 - sp.size))
        dkpa = tuple(int(round(v * 10)) for v in sp)
        pump_mask, valve_mask = _mask(pumps), _mask(valves)
        self._out_counter = (self._out_counter + 1) & 0xFFFF
        self._exchange(
            m.SetOutputs(
                setpoint_dkpa=dkpa,
                pump_mask=pump_mask,
                valve_mask=valve_mask,
                session=self._session,
                counter=self._out_counter,
            )
        )
        self._outputs_active = bool(pump_mask or valve_mask)

    def set_watchdog(self, timeout_ms: int) -> None:
        """Host-link watchdog timeout (RAM only; CONFIG_SET WATCHDOG_MS stores it).

        Parameters
        ----------
        timeout_ms : int
            Timeout, ms (100..10000).

        Raises
        ------
        NakError
            A timeout outside 100..10000 ms (OUT_OF_RANGE).
        """
        self._exchange(m.SetWatchdog(timeout_ms=int(timeout_ms)))

    def start_stream(self, rate_hz: int = 50, channels: int | Sequence[str] = ALL_CHANNELS) -> None:
        """Start SAMPLE telemetry (restarting a stream already running).

        Parameters
        ----------
        rate_hz : int
            Sample rate, Hz (10..135, the SAMPLE_RATE_HZ limits).
        channels : int or sequence of str
            Channel mask (ADC0..2, IMU, ESTIMATES bits; ALL_CHANNELS for all) or channel names.

        Raises
        ------
        NakError
            A rate outside the limits (OUT_OF_RANGE).
        """
        if self._streaming:
            self.stop_stream()
        mask = _channel_mask(channels)
        self._samples.clear()
        self._next_tseq = 0  # each stream numbers its SAMPLE frames from 0
        self._exchange(m.StartStream(rate_hz=int(rate_hz), channel_mask=mask))
        self._rate_hz = int(rate_hz)
        self._streaming = True

    def stop_stream(self) -> None:
        """Stop SAMPLE telemetry; samples already received stay readable."""
        self._exchange(m.StopStream())
        self._streaming = False

    @property
    def streaming(self) -> bool:
        return self._streaming

    def samples(self, n: int | None = None, *, timeout_s: float | None = None) -> Iterator[Sample]:
        """Yield samples in arrival order; lost frames are counted in ``stats.samples_lost``.

        Parameters
        ----------
        n : int or None
            Samples to yield (None: forever).
        timeout_s : float or None
            Longest wait for one sample, s (None: 1 s or five sample periods, whichever is longer,
            times ``timeout_scale``).

        Yields
        ------
        Sample
            The next sample (device time in us, dR in 0.01 %, estimates in LSB, ...).

        Raises
        ------
        DeviceError
            No sample for ``timeout_s``.
        """
        if timeout_s is None:
            period = 1.0 / self._rate_hz if self._rate_hz else 0.1
            timeout_s = max(1.0, 5 * period) * self.timeout_scale
        count = 0
        while n is None or count < n:
            if not self._samples:
                end = time.monotonic() + timeout_s
                while not self._samples:
                    left = end - time.monotonic()
                    if left <= 0:
                        raise DeviceError(f"no SAMPLE from {self.url} for {timeout_s:.1f} s")
                    self._pump(left)
            s = self._samples.popleft()
            if s.target_lsb is not None and self._out_scale is None:
                # A board found controlling (AUTOSTART 2): its model's scale gives the targets' units.
                self._control_model()
                for q in (s, *self._samples):
                    if q.target_lsb is not None:
                        q.target = self._target_units(q.target_lsb)
            yield s
            count += 1

    def drain_samples(self) -> list[Sample]:
        """Samples received and not yet read, without waiting (e.g. after stop_stream).

        Returns
        -------
        list of Sample
            In arrival order.
        """
        self._pump(0.0)
        out = list(self._samples)
        self._samples.clear()
        return out

    def read_samples(self, n: int, *, timeout_s: float | None = None) -> SampleBlock:
        """The next ``n`` samples as arrays, with the frames lost meanwhile in ``.lost``.

        Parameters
        ----------
        n : int
            Samples to read.
        timeout_s : float or None
            Longest wait for one sample, s (as :meth:`samples`).

        Returns
        -------
        SampleBlock
            The samples as arrays.

        Raises
        ------
        DeviceError
            No sample for ``timeout_s``.
        """
        lost0 = self.stats.samples_lost
        samples = list(self.samples(n, timeout_s=timeout_s))
        return SampleBlock.from_samples(samples, lost=self.stats.samples_lost - lost0)

    def write_model(
        self, blob: bytes, *, replace: bool | None = None, validate: bool = True, format_version: int | None = None
    ) -> ModelInfo:
        """Write a model blob: MODEL_BEGIN, MODEL_CHUNKs of 112 bytes, MODEL_COMMIT, then MODEL_INFO.

        The blob is checked first exactly as the firmware checks it (format, CRC, structure, size):
        a bad blob raises ModelError before anything is sent. The device writes it beside the
        running model, which keeps running until the new one is whole and checked.

        Parameters
        ----------
        blob : bytes
            The model blob (``QuantResult.blob.to_bytes()``).
        replace : bool or None
            When the new model does not fit beside the running one in the EEPROM's model area:
            False raises ModelError, True erases the running model first (the board has none until
            the write completes), None does the same with a warning.
        validate : bool
            Check the blob on the host first; False sends it as it is (to test the device's checks).
        format_version : int or None
            Format version announced in MODEL_BEGIN (None: the blob's own).

        Returns
        -------
        ModelInfo
            The stored model as the device reports it.

        Raises
        ------
        ModelError
            A blob that is not valid, or one that does not fit beside the running model with
            ``replace=False``.
        NakError
            The device refused a step.
        DeviceError
            The device reports another CRC or length after the write.
        """
        from porosense.protocol.model_blob import ModelBlob, blob_crc

        blob = bytes(blob)
        if validate:
            ModelBlob.from_bytes(blob)
        if format_version is None:
            format_version = blob[2] if len(blob) >= 3 else 0
        crc = blob_crc(blob)
        if replace:
            self.erase_model()
        try:
            self._exchange(m.ModelBegin(length=len(blob), crc=crc, format_version=format_version))
        except NakError as exc:
            if exc.code != Result.TOO_LARGE or replace or not self.model_info().valid:
                raise
            if replace is False:
                raise ModelError(
                    f"the model ({len(blob)} bytes) does not fit beside the running one "
                    f"({exc.detail} bytes too many); replace it (flash --replace) to erase it "
                    "first"
                ) from None
            import warnings

            warnings.warn(
                f"the model ({len(blob)} bytes) does not fit beside the running one: erasing it "
                "first (no model on the board until the write completes)",
                stacklevel=2,
            )
            self.erase_model()
            self._exchange(m.ModelBegin(length=len(blob), crc=crc, format_version=format_version))
        for offset in range(0, len(blob), MODEL_CHUNK_BYTES):
            self._exchange(m.ModelChunk(offset=offset, data=blob[offset : offset + MODEL_CHUNK_BYTES]))
        self._exchange(m.ModelCommit())
        info = self.model_info()
        if not info.valid or info.crc != crc or info.length != len(blob):
            raise DeviceError(f"model written but the device reports {info}")
        return info

    def sample_rate_hz(self) -> int:
        """The board's configured sample rate (SAMPLE_RATE_HZ).

        Returns
        -------
        int
            Sample rate, Hz.
        """
        return int(self.config_get("SAMPLE_RATE_HZ"))

    def check_model_rate(self, blob: bytes, *, set_rate: bool = False) -> int:
        """Compare the blob's sample period with the board's sample rate.

        Parameters
        ----------
        blob : bytes
            The model blob (either store's size).
        set_rate : bool
            On a mismatch, set and save the board's SAMPLE_RATE_HZ to the model's rate (which must be
            a whole number of Hz).

        Returns
        -------
        int
            The board's sample rate, Hz (after the change with ``set_rate``).

        Raises
        ------
        ModelError
            The rates differ (without ``set_rate``), or the model's rate is not a whole number of Hz.
        """

        model = ModelBlob.from_bytes(bytes(blob), max_length=FLASH_BLOB_MAX)  # either store's
        board = self.sample_rate_hz()
        if round(1e6 / board) == model.ts_us:
            return board
        model_hz = model.rate_hz
        if not set_rate:
            raise ModelError(
                f"the model was identified at {model_hz:g} Hz (Ts {model.ts_us / 1000:g} ms) but the "
                f"board samples at {board} Hz: re-identify at {board} Hz, or flash with --set-rate "
                f"to run the board at {model_hz:g} Hz"
            )
        whole_hz = max(int(round(model_hz)), 1)
        if round(1e6 / whole_hz) != model.ts_us:  # the blob keeps Ts in whole microseconds
            raise ModelError(
                f"the model's rate {model_hz:g} Hz is not a whole number of Hz; the board cannot sample at it"
            )
        self.config_set("SAMPLE_RATE_HZ", whole_hz)
        self.config_save()
        return self.sample_rate_hz()

    def model_info(self) -> ModelInfo:
        """The stored model.

        Returns
        -------
        ModelInfo
            Status, length (bytes), CRC, inputs, outputs, out_scale and slot.
        """
        return ModelInfo.from_message(self._exchange(m.ModelInfo()))

    def erase_model(self) -> None:
        """Erase the stored model; the estimator turns off."""
        self._exchange(m.ModelErase())

    def read_model_bytes(self, offset: int, n: int) -> bytes:
        """Part of the stored blob.

        Parameters
        ----------
        offset : int
            First byte, from the blob's start.
        n : int
            Bytes to read (at most 112).

        Returns
        -------
        bytes
            ``n`` bytes.

        Raises
        ------
        DeviceError
            An answer at another offset or of another length.
        """
        reply = self._exchange(m.ModelRead(offset=int(offset), length=int(n)))
        if reply.offset != offset or len(reply.data) != n:
            raise DeviceError(
                f"MODEL_DATA at offset {reply.offset} with {len(reply.data)} bytes, expected {offset}, {n}"
            )
        return bytes(reply.data)

    def read_model(self) -> bytes:
        """Read the stored blob back.

        Returns
        -------
        bytes
            The whole blob.

        Raises
        ------
        DeviceError
            No valid model on the board, or a reply at the wrong offset.
        """
        info = self.model_info()
        if not info.valid:
            raise DeviceError(f"no model to read: {info}")
        out = bytearray()
        while len(out) < info.length:
            n = min(MODEL_CHUNK_BYTES, info.length - len(out))
            reply = self._exchange(m.ModelRead(offset=len(out), length=n))
            if reply.offset != len(out) or not reply.data:
                raise DeviceError(f"MODEL_DATA at offset {reply.offset}, expected {len(out)}")
            out += reply.data
        return bytes(out)

    def replay(self, dr_centi, *, reset: bool = True, return_flags: bool = False):
        """Run the on-device estimator on given inputs (REPLAY, 16 samples per command).

        Parameters
        ----------
        dr_centi : array_like, shape (N, 3)
            Inputs, dR in 0.01 % (int16).
        reset : bool
            Zero the estimator state before the first chunk.
        return_flags : bool
            Also return the flags of each chunk.

        Returns
        -------
        estimates : ndarray of int16, shape (N, 3)
            The estimator's outputs, estimate LSB (times ``ModelInfo.out_scale`` for output units).
        flags : ndarray of uint8
            Per chunk of 16 samples, the saturation flags; only with ``return_flags``.

        Raises
        ------
        ValueError
            Inputs of another shape or outside int16.
        DeviceError
            A reply with another number of values.
        """
        x = np.asarray(dr_centi)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError("replay inputs must have shape (N, 3)")
        if np.any(x < -32768) or np.any(x > 32767):
            raise ValueError("replay inputs must fit in int16")
        x = x.astype(np.int16)
        out = np.zeros_like(x)
        flags = []
        for k in range(0, len(x), REPLAY_SAMPLES):
            chunk = x[k : k + REPLAY_SAMPLES]
            reply = self._exchange(m.Replay(reset=int(reset and k == 0), dr_centi=tuple(int(v) for v in chunk.ravel())))
            est = np.asarray(reply.estimate, dtype=np.int16)
            if est.size != chunk.size:
                raise DeviceError(f"REPLAY_RESULT holds {est.size} values for {chunk.size} inputs")
            out[k : k + len(chunk)] = est.reshape(chunk.shape)
            flags.append(reply.flags)
        self._replay_flags = flags
        return (out, np.asarray(flags, dtype=np.uint8)) if return_flags else out

    def calibrate_r0(self, n_samples: int = 16, channels: int = 0b111) -> tuple[float, ...]:
        """Average samples at rest and take them as R0 (the actuator must be unloaded and vented).

        Parameters
        ----------
        n_samples : int
            Samples averaged (1..64).
        channels : int
            Channel mask (bit i = channel i).

        Returns
        -------
        tuple of float
            R0 per channel, ohm.
        """
        reply = self._exchange(m.CalibrateR0(n_samples=int(n_samples), channel_mask=int(channels)))
        return tuple(float(r) for r in reply.r0_ohm)

    def set_r0(self, r0_ohm: Sequence[float], channels: int = 0b111) -> None:
        """Set R0 of the masked channels in RAM.

        Parameters
        ----------
        r0_ohm : sequence of float
            R0 per channel, ohm (up to 3; missing channels get 0).
        channels : int
            Channel mask (bit i = channel i) of the values that apply.
        """
        r0 = tuple(float(v) for v in np.pad(np.asarray(r0_ohm, dtype=float), (0, 3 - len(r0_ohm))))
        self._exchange(m.SetR0(channel_mask=int(channels), r0_ohm=r0))

    def status(self) -> DeviceStatus:
        """Health counters and flags.

        Returns
        -------
        DeviceStatus
            STATUS_REPLY's counters.
        """
        return DeviceStatus.from_message(self._exchange(m.Status()))

    def config_get(self, key: str | int) -> int:
        """One configuration value.

        Parameters
        ----------
        key : str or int
            Key name (``"SAMPLE_RATE_HZ"``, ``"WATCHDOG_MS"``, ...) or number.

        Returns
        -------
        int
            The value, in the key's unit (protocol/messages.toml).

        Raises
        ------
        ValueError
            An unknown key name.
        """
        k = _config_key(key)
        reply = self._exchange(m.ConfigGet(key=k))
        if reply.key != k:
            raise DeviceError(f"CONFIG_VALUE for key {reply.key}, asked for {k}")
        return reply.value

    def config_set(self, key: str | int, value: int) -> None:
        """Set one configuration value in RAM (config_save stores it).

        Parameters
        ----------
        key : str or int
            Key name or number.
        value : int
            The value, in the key's unit.

        Raises
        ------
        NakError
            A value outside the key's range (OUT_OF_RANGE).
        """
        self._exchange(m.ConfigSet(key=_config_key(key), value=int(value)))

    def config_all(self) -> dict[str, int]:
        """Every configuration key known to this host, by name.

        Returns
        -------
        dict of str to int
            Key name to value.
        """
        return {k.name: self.config_get(k) for k in ConfigKey}

    def config_save(self) -> None:
        """Write the configuration to EEPROM."""
        self._exchange(m.ConfigSave())

    def config_reset(self) -> None:
        """Restore the documented defaults in RAM and EEPROM."""
        self._exchange(m.ConfigReset())

    def reset(self, wait_s: float = 3.0) -> HelloInfo:
        """Reset the board, wait for it to boot and handshake again.

        Parameters
        ----------
        wait_s : float
            Longest wait for the board to answer HELLO, s.

        Returns
        -------
        HelloInfo
            The new handshake.
        """
        self._exchange(m.Reset())
        time.sleep(0.05 * self.timeout_scale)
        return self.after_reset(wait_s=wait_s)

    def after_reset(self, wait_s: float = 3.0) -> HelloInfo:
        """The board was reset (RESET, an upload, the reset button): forget the stream and output
        state, wait for it to boot and handshake again (a new output session).

        Parameters
        ----------
        wait_s : float
            Longest wait for the board to answer HELLO, s.

        Returns
        -------
        HelloInfo
            The new handshake.
        """
        self._next_tseq = self._next_eseq = None  # the counters restart with the firmware
        self._streaming = False
        self._outputs_active = False
        self._samples.clear()
        return self.hello(wait_s=wait_s)

    # ------------------------------------------------------------------ strain control

    def _control_model(self) -> tuple[tuple[float, ...], int]:
        """out_scale of the running model (zeros without one) and its CRC."""
        info = self.model_info()
        scale = tuple(info.out_scale) if info.valid else ()
        self._out_scale = scale or None
        return scale, info.crc if info.valid else 0

    def _control_rate_hz(self) -> int:
        return self._rate_hz if self._streaming else self.sample_rate_hz()

    def set_control_gains(self, gains, *, save: bool = False) -> None:
        """PI gains of the strain controller.

        Quantised to the board's fixed point for the running model and the sample rate (the
        stream's, else SAMPLE_RATE_HZ).

        Parameters
        ----------
        gains : ControlGains or sequence of ControlGains
            One for all channels or one per channel, in the model's output units (kPa per unit, kPa
            per unit-second, units per second).
        save : bool
            Store them on the board (versioned, CRC) for AUTOSTART 2.

        Raises
        ------
        DeviceError
            No valid model on the board.
        InputError
            Gains the board's fixed point cannot hold.
        """

        gains = control.per_channel(gains)
        scale, crc = self._control_model()
        if not scale:
            raise DeviceError("no valid model on the board: control gains are set per model (flash one first)")
        rate = self._control_rate_hz()
        fixed = control.to_fixed(gains, scale, rate)
        self._exchange(m.ControlGains(**fixed, model_crc=crc, rate_hz=rate, save=int(bool(save))))
        self._gains, self._gains_for = gains, (crc, rate)

    def control_gains(self):
        """The gains on the board, per channel, as quantised there.

        Returns
        -------
        tuple of ControlGains
            Per channel, in the model's output units; zero gains with no slew limit (inf) where none
            were set.

        Raises
        ------
        DeviceError
            Gains made for another model than the running one.
        """

        r = self._exchange(m.ControlGainsGet())
        scale, crc = self._control_model()
        if r.rate_hz and r.model_crc != crc:
            raise DeviceError(
                f"the board's control gains were made for another model (crc 0x{r.model_crc:04X}, "
                f"running 0x{crc:04X}): set them again"
            )
        return control.from_fixed(r.kp_q16, r.ki_q22, r.slew_q4, scale, r.rate_hz)

    def _refresh_gains(self) -> tuple[float, ...]:
        """Resend the host's gains when the model or the rate changed since they were sent."""

        scale, crc = self._control_model()
        rate = self._control_rate_hz()
        if self._gains is not None and scale and self._gains_for != (crc, rate):
            fixed = control.to_fixed(self._gains, scale, rate)
            self._exchange(m.ControlGains(**fixed, model_crc=crc, rate_hz=rate, save=0))
            self._gains_for = (crc, rate)
        return scale

    def _control_start(self, mode: int, targets_lsb, channels: int) -> None:
        self._out_counter = (self._out_counter + 1) & 0xFFFF
        self._exchange(
            m.ControlStart(
                mode=mode,
                channel_mask=int(channels),
                target=tuple(targets_lsb),
                session=self._session,
                counter=self._out_counter,
            )
        )
        self._outputs_active = True

    def start_control(self, targets, *, channels: int = 0b001) -> None:
        """Hold constant targets with the on-board PI on the streamed estimate.

        Arms the host-link watchdog like set_outputs: keep sending commands (e.g. ping).

        Parameters
        ----------
        targets : float or sequence of float
            Target, output units (e.g. % strain), one for all channels or one per channel.
        channels : int
            Channel mask (bit i = channel i) of the channels controlled.

        Raises
        ------
        NakError
            No valid model (NO_MODEL), not streaming estimates (BAD_STATE), or a target outside the
            model's output range (OUT_OF_RANGE).
        """

        scale = self._refresh_gains() or (1.0,) * 3
        self._control_start(0, control.to_lsb(targets, scale, int(channels)), channels)

    def write_trajectory(self, t_s, targets, *, repeat: bool = False) -> None:
        """Store piecewise-linear targets on the board (not while streaming).

        Chunked and CRC-checked, kept over resets; a torn write keeps the previous one.

        Parameters
        ----------
        t_s : array_like, shape (n,)
            Times, s, increasing from 0 (10 ms resolution, at most 327.67 s between points).
        targets : array_like, shape (n,) or (n, 3)
            Targets, output units: one column for every controlled channel or one per channel.
        repeat : bool
            Loop the trajectory.

        Raises
        ------
        DeviceError
            No valid model on the board.
        InputError
            Times or targets the board's record cannot hold (at most 13 points of one column, 6 of
            three).
        """

        scale, _ = self._control_model()
        if not scale:
            raise DeviceError("no valid model on the board: trajectory targets are in its output units")
        rec = control.trajectory_record(t_s, targets, scale, repeat=repeat)
        for off in range(0, len(rec), TRAJECTORY_CHUNK_BYTES):
            self._exchange(m.TrajectoryChunk(total=len(rec), offset=off, data=rec[off : off + TRAJECTORY_CHUNK_BYTES]))

    def start_trajectory(self, *, channels: int = 0b001) -> None:
        """Run the stored trajectory.

        Parameters
        ----------
        channels : int
            Channel mask (bit i = channel i); a 1-column trajectory drives each of them, a 3-column
            one channel i with column i.
        """
        self._refresh_gains()
        self._control_start(1, (0, 0, 0), channels)

    def stop_control(self) -> None:
        """Stop control: regulators to 0, pumps off, valves vent."""
        self._exchange(m.ControlStop())
        self._outputs_active = False

    # ------------------------------------------------------------------ raw access

    def send_raw(self, data: bytes) -> None:
        """Write bytes as they are (tests of the device's frame checks).

        Parameters
        ----------
        data : bytes
            Bytes to write.
        """
        self.link.write(data)

    def exchange_raw(
        self,
        msg_type: int,
        payload: bytes = b"",
        *,
        seq: int | None = None,
        version: int | None = None,
        timeout_s: float = 0.3,
    ):
        """Send one hand-built frame once and return its answer.

        Parameters
        ----------
        msg_type : int
            Message type id (any, also unknown ones).
        payload : bytes
            Payload as it is.
        seq : int or None
            Sequence number (None: the next one).
        version : int or None
            Header version byte (None: this host's).
        timeout_s : float
            Wait for the answer, s (times ``timeout_scale``).

        Returns
        -------
        Frame or None
            Its reply, ACK or NAK with the same sequence number, or None.
        """
        seq = self._next_seq() if seq is None else seq & 0xFF
        self.link.write(encode_frame(msg_type, seq, payload, VERSION_BYTE if version is None else version))
        cls = MESSAGES.get(msg_type)
        reply_type = _reply_type(msg_type) if cls is not None and cls.REPLY else MsgType.ACK
        return self._await(seq, msg_type, reply_type, timeout_s * self.timeout_scale)

    def command(self, message, *, seq: int | None = None, deadline_s: float | None = None):
        """Send any command message and return its answer.

        Parameters
        ----------
        message : Message
            A generated message object (``porosense.protocol.Ping(nonce=1)``, ...).
        seq : int or None
            Sequence number (None: the next one).
        deadline_s : float or None
            The device's deadline to answer, s (None: the catalogue's).

        Returns
        -------
        Message
            The reply message (ACK for commands without one).

        Raises
        ------
        NakError
            The device refused it.
        DeviceError
            No answer after the retries.
        """
        return self._exchange(message, seq=seq, deadline_s=deadline_s)

    # ------------------------------------------------------------------ machinery

    def _next_seq(self) -> int:
        self._seq = (self._seq + 1) & 0xFF
        return self._seq

    def _timeout_s(self, cmd_type: int, frame_len: int, deadline_s: float | None) -> float:
        deadline = MESSAGES[cmd_type].DEADLINE_MS / 1000.0 if deadline_s is None else deadline_s
        link_bytes = frame_len + _max_frame_bytes(_reply_type(cmd_type))
        return (deadline + link_bytes * 10.0 / self.baudrate + _LATENCY_S) * self.timeout_scale

    def _exchange(self, message, *, seq=None, deadline_s=None, wait_total_s=None, raw=False):
        """Send ``message``, retry with the same sequence number, return the matching answer."""
        if seq is None:
            seq = self._next_seq()
        else:
            self._seq = seq = seq & 0xFF
        cmd_type = message.TYPE
        reply_type = _reply_type(cmd_type)
        data = encode_message(message, seq)
        timeout = self._timeout_s(cmd_type, len(data), deadline_s)
        attempts = self.retries + 1
        if wait_total_s is not None:  # a board that may be booting: repeat every 250 ms
            timeout = max(timeout, _HELLO_REPEAT_S)
            attempts = max(attempts, int(wait_total_s / timeout) + 1)
        self.stats.commands += 1
        for attempt in range(attempts):
            if attempt:
                self.stats.retries += 1
            self.link.write(data)
            frame = self._await(seq, cmd_type, reply_type, timeout)
            if frame is not None:
                break
        else:
            name = MsgType(cmd_type).name
            raise DeviceError(
                f"no answer to {name} from {self.url} after {attempts} attempts of {timeout * 1000:.0f} ms"
            )
        if frame.type == MsgType.NAK:
            nak = frame.message()
            raise NakError(cmd_type, nak.code, nak.detail)
        if raw:
            return frame
        try:
            return frame.message()
        except ValueError as exc:
            raise DeviceError(f"malformed {frame.name} from {self.url}: {exc}") from None

    def _await(self, seq: int, cmd_type: int, reply_type: int, timeout: float):
        """The frame answering (seq, cmd_type), or None after ``timeout`` seconds.

        Telemetry queued on the link ahead of the answer delays it by its transmission
        time, so the deadline grows by that time (at most _MAX_QUEUE_WAIT_S).
        """
        start = time.monotonic()
        samples0 = self.stats.samples
        while True:
            queued_s = (self.stats.samples - samples0) * _SAMPLE_WIRE_BYTES * 10.0 / self.baudrate
            left = start + timeout + min(queued_s, _MAX_QUEUE_WAIT_S) * self.timeout_scale - time.monotonic()
            if left <= 0:
                return None
            for frame in self._pump(left):
                if frame.seq == seq and self._answers(frame, cmd_type, reply_type):
                    return frame
                self.stats.stale_replies += 1

    @staticmethod
    def _answers(frame, cmd_type: int, reply_type: int) -> bool:
        if frame.type in (MsgType.ACK, MsgType.NAK):
            return (
                len(frame.payload) >= 1
                and frame.payload[0] == cmd_type
                and (frame.type == MsgType.NAK or reply_type == MsgType.ACK)
            )
        return frame.type == reply_type

    def _pump(self, wait_s: float) -> list:
        """Read what the link holds (waiting up to ``wait_s``); queue samples, return other frames."""
        data = self.link.read(wait_s)
        if not data:
            return []
        others = []
        for frame in self._decoder.feed(data):
            if frame.type in (MsgType.SAMPLE, MsgType.CONTROL_SAMPLE):
                self._on_sample(frame)
            elif frame.type == MsgType.ERROR:
                if self._next_eseq is not None:  # ERROR frames have their own counter
                    self.stats.errors_lost += (frame.seq - self._next_eseq) & 0xFF
                self._next_eseq = (frame.seq + 1) & 0xFF
                try:
                    self.errors.append(frame.message())
                    self.stats.errors_received += 1
                except ValueError:
                    pass
            else:
                others.append(frame)
        return others

    def _on_sample(self, frame) -> None:
        control = frame.type == MsgType.CONTROL_SAMPLE
        try:
            t_us, mask, status, *vals = (_CONTROL_SAMPLE if control else _SAMPLE).unpack(frame.payload)
        except struct.error:
            return
        if self._next_tseq is not None:
            self.stats.samples_lost += (frame.seq - self._next_tseq) & 0xFF
        self._next_tseq = (frame.seq + 1) & 0xFF
        if self._t_last_raw is not None and t_us < self._t_last_raw and self._t_last_raw - t_us > 1 << 31:
            self._t_wraps += 1
        self._t_last_raw = t_us
        self.stats.samples += 1
        self._samples.append(
            Sample(
                frame.seq,
                t_us + (self._t_wraps << 32),
                mask,
                status,
                tuple(vals[0:3]),
                tuple(vals[3:6]),
                tuple(vals[6:9]),
                tuple(vals[9:12]),
                *(self._control_fields(vals[12:15], vals[15:18]) if control else ()),
            )
        )

    def _control_fields(self, target_lsb, command_dkpa) -> tuple:
        return self._target_units(target_lsb), tuple(v / 10.0 for v in command_dkpa), tuple(target_lsb)

    def _target_units(self, target_lsb) -> tuple[float, ...]:
        scale = self._out_scale or ()
        return tuple(math.nan if v == _NO_TARGET or i >= len(scale) else v * scale[i] for i, v in enumerate(target_lsb))

    @property
    def decoder_counters(self) -> dict[str, int]:
        """Frames the host decoder accepted and dropped, by reason."""
        return dict(self._decoder.counters)


_SAMPLE = m.Sample._FMT
_CONTROL_SAMPLE = m.ControlSample._FMT
_NO_TARGET = -32768


def _mask(bits) -> int:
    if isinstance(bits, (int, np.integer)):
        return int(bits) & 0xFF
    return sum(1 << i for i, on in enumerate(bits) if on)


def _channel_mask(channels) -> int:
    if isinstance(channels, (int, np.integer)):
        return int(channels)
    mask = 0
    for name in channels:
        try:
            mask |= m.Channel[str(name).upper()]
        except KeyError:
            raise ValueError(f"unknown stream channel {name!r}; use {[c.name for c in m.Channel]}") from None
    return mask


def _config_key(key) -> int:
    if isinstance(key, (int, np.integer)):
        return int(key)
    try:
        return int(ConfigKey[str(key).upper()])
    except KeyError:
        raise ValueError(f"unknown configuration key {key!r}; use {[k.name for k in ConfigKey]}") from None


def blob_crc(blob: bytes) -> int:
    """The CRC that identifies a model blob (MODEL_BEGIN.crc, MODEL_INFO.crc).

    The same routine as porosense.protocol.model_blob.blob_crc.

    Parameters
    ----------
    blob : bytes
        A whole model blob, its 2-byte CRC trailer included.

    Returns
    -------
    int
        CRC-16/MCRF4XX of every byte before the trailer, 0..0xFFFF.
    """

    return crc(blob)
