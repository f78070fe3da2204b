"""The Emulator: the firmware core (BoardCore) served over TCP or a pty from a background thread.

Two timings:

* lockstep (default, for tests): while streaming, the board's clock advances one sample
  period per SAMPLE and the next sample is made as soon as the previous one has left, so the
  host receives correctly timestamped samples as fast as it reads them (a host that stops
  reading stops the board's clock). When not streaming the clock follows the wall clock.
  While the board drives the plant, its clock leads the host's last frame by at most
  LOCKSTEP_LEAD_S plus the wall-clock time since that frame: the kernel's socket buffers
  hold thousands of samples, and a board that ran that far ahead would see a host pinging
  every few samples as silent for seconds (its link watchdog would cut the outputs).
* real time (``realtime=True``): the clock follows the wall clock (times ``speed``) and
  the UART sends at 115200 baud from a 64-byte transmit buffer; telemetry that does not fit
  is dropped and counted, like on the board.
"""

from __future__ import annotations

import bisect
import select
import threading
import time
from dataclasses import dataclass

import numpy as np

from porosense.emulator.board import BoardCore
from porosense.emulator.endpoints import make_endpoint
from porosense.emulator.faults import Faults, FaultyLink
from porosense.emulator.version_claim import HelloRewrite
from porosense.firmware.corelib import RESET_EXTERNAL

# Real-time mode: the UART sends at BAUD (10 bits per byte) from a 64-byte transmit buffer;
# a SAMPLE that does not fit in it is dropped, like on the board.
REALTIME_TX_BUFFER = 64
BAUD = 115200
FAST_BATCH_BYTES = 1024
MAX_CATCH_UP_S = 1.0
WRAP_US = float(1 << 32)  # the device's microsecond clock wraps here
IDLE_WAIT_S = 0.02
# The board's loop runs the link watchdog about every millisecond; while the emulated board
# drives an output, its loop wakes as often, so that outputs are cut when a real board would.
DRIVING_WAIT_S = 0.001
LOCKSTEP_LEAD_S = 1.0  # device s a driving board may run ahead of the host's last frame


@dataclass
class EmulatorStats:
    """Counters of the board and of the faulty link, for tests and benchmarks."""

    board: dict
    link: dict
    connections: int

    def to_dict(self) -> dict:
        return {"board": self.board, "link": self.link, "connections": self.connections}


class Emulator:
    """The porosense board without hardware, reachable at ``.url``: the firmware's core
    (firmware/lib/core, built for this computer) over the simulator plant.

        with Emulator(actuator="contractor") as emu:
            with Device.open(emu.url) as dev: ...

    ``listen``: "tcp://127.0.0.1:0" (a free port) or "pty". ``faults``: a Faults, or None.
    ``proto_version``: the (major, minor) the board claims (tests of version refusal: the
    link rewrites the firmware's frames).
    ``truth_log``: remember the plant's ground truth at every sample (see :meth:`truth`).
    ``max_catch_up_s``: in real time, how far (device s) a late loop catches up before the
    missed ticks count as overruns.
    ``clock_offset_us``: the device clock's value at power-on. ``plant``: any object with the
    porosense.sim plant interface instead of ``porosense.sim.make_plant(actuator, ...)``.
    """

    def __init__(
        self,
        actuator: str = "contractor",
        *,
        porosity=None,
        load_g: float = 0.0,
        seed: int = 0,
        effects=None,
        listen: str = "tcp://127.0.0.1:0",
        realtime: bool = False,
        speed: float = 1.0,
        faults: Faults | None = None,
        proto_version: tuple[int, int] | None = None,
        reset_on_connect: bool = False,
        clock_offset_us: int = 0,
        plant=None,
        truth_log: bool = False,
        max_catch_up_s: float = MAX_CATCH_UP_S,
    ):
        self.actuator = actuator
        self.realtime = realtime
        self.speed = float(speed)
        self.faults = faults or Faults()
        self.link = FaultyLink(self.faults)
        self.reset_on_connect = reset_on_connect
        from porosense.sim import make_plant

        self._plant = (
            plant
            if plant is not None
            else make_plant(actuator, porosity=porosity, load_g=load_g, seed=seed, effects=effects)
        )
        self._out = bytearray()
        self._tokens = 0.0  # real time: bytes the UART may send now
        self._t_tokens_us = 0  # device time of that credit
        self._host_frame = (0, time.monotonic())  # (board time us, wall s) of the host's last bytes
        self._lock = threading.RLock()
        self._hello = HelloRewrite(version=tuple(proto_version) if proto_version else None)
        self.core = BoardCore(
            self._plant,
            send=self._on_bytes,
            tx_room=self._tx_room,
            faults=self.faults,
            clock_offset_us=clock_offset_us,
        )
        self.max_catch_up_s = float(max_catch_up_s)
        if truth_log:
            self.core.truth_log = {}
        self.endpoint = make_endpoint(listen)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ public

    @property
    def url(self) -> str:
        """pyserial URL of the board (socket://127.0.0.1:PORT or /dev/pts/N)."""
        return self.endpoint.url

    def start(self) -> Emulator:
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name="porosense-emulator", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        self.endpoint.close()

    def __enter__(self) -> Emulator:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def serve_forever(self) -> None:
        """Run in the calling thread until KeyboardInterrupt (the CLI)."""
        try:
            self._serve()
        finally:
            self.endpoint.close()

    @property
    def stats(self) -> EmulatorStats:
        with self._lock:
            return EmulatorStats(
                board=self.core.stats.to_dict(),
                link=self.link.damage.to_dict(),
                connections=self.endpoint.connections,
            )

    def truth(self, t_us) -> dict[str, np.ndarray]:
        """Ground truth of the plant at device times ``t_us`` (us, as in SAMPLE; needs
        ``truth_log=True``): one array per scalar truth key, interpolated between samples."""
        log = self.core.truth_log
        if log is None:
            raise ValueError("the emulator was started without truth_log=True")
        t_us = np.asarray(t_us, dtype=float)
        with self._lock:
            times = log.get("t_us", [])
            if not times or t_us.size == 0:
                return {}
            # SAMPLE times wrap every 2^32 us (71.6 min); the log's do not. Re-base the query on
            # the log's clock: its first sample lies within one wrap before the latest entry.
            first = float(t_us.min())
            first_mod = first % WRAP_US
            wraps = np.floor((times[-1] - first_mod) / WRAP_US)
            t_us = t_us - (first - first_mod) + wraps * WRAP_US
            # Only the part of the log that the query spans (the log grows all run long).
            lo = max(0, bisect.bisect_left(times, float(t_us.min())) - 1)
            hi = min(len(times), bisect.bisect_right(times, float(t_us.max())) + 1)
            window = {k: np.asarray(v[lo:hi]) for k, v in log.items()}
        t = window.pop("t_us")
        return {k: np.interp(t_us, t, v) for k, v in window.items()}

    def disconnect(self, adc: bool | None = None, imu: bool | None = None) -> None:
        """Unplug (True) or replug (False) the ADC and/or the IMU while running."""
        with self._lock:
            self.core.plug(adc=None if adc is None else not adc, imu=None if imu is None else not imu)

    def reset_now(self) -> None:
        """Cut the power of the board now (it reboots; nothing pending is answered)."""
        with self._lock:
            self.core.power_cycle()

    def program_flash(self, pages, n_pages: int | None = None) -> int:
        """Upload (flash address, 128 bytes) pages into the flash model store and reset the
        board, as avrdude -D and the bootloader do; ``n_pages`` stops early (a torn upload)."""
        with self._lock:
            done = self.core.fw.program_flash(pages, n_pages)
            self.core.boot(RESET_EXTERNAL)
        return done

    def set_faults(self, **rates) -> None:
        """Change fault rates while running (rx_corrupt=..., tx_drop=..., ...)."""
        with self._lock:
            for k, v in rates.items():
                if not hasattr(self.faults, k):
                    raise ValueError(f"unknown fault {k!r}")
                setattr(self.faults, k, v)

    # ------------------------------------------------------------------ machinery

    def _on_bytes(self, data: bytes, sample_t_us: int | None) -> None:
        data = self._hello.rewrite(data)
        if not (self.faults.tx_corrupt or self.faults.tx_drop):
            self._out += self.link.board_to_host(data)
            return
        # Damage frame by frame so that the link knows which SAMPLE it destroyed: the bytes
        # of a sample tick start with its SAMPLE frame.
        start = 0
        while start < len(data):
            end = data.find(b"\x00", start)
            end = len(data) if end < 0 else end + 1
            self._out += self.link.board_to_host(data[start:end], sample_t_us if start == 0 else None)
            start = end

    def _tx_room(self) -> int:
        if not self.realtime:
            return 1 << 30  # lockstep: the board waits for the host instead of dropping
        return max(0, REALTIME_TX_BUFFER - len(self._out))

    def _flush(self) -> None:
        if self.realtime:
            self._flush_paced()
            return
        while self._out:
            n = self.endpoint.send(bytes(self._out[:65536]))
            if n <= 0:
                return
            del self._out[:n]

    def _flush_paced(self, upto_us: int | None = None) -> None:
        """Real time: hand bytes to the endpoint no faster than the UART sends them, counted
        in device time up to ``upto_us`` (a late loop catches up: the UART kept shifting)."""
        T = self.core.T_us if upto_us is None else upto_us
        if T < self._t_tokens_us:
            T = self._t_tokens_us
        credit = (T - self._t_tokens_us) * (BAUD / 10.0) * 1e-6
        self._tokens = min(self._tokens + max(credit, 0.0), max(REALTIME_TX_BUFFER, len(self._out)))
        self._t_tokens_us = T
        n = min(int(self._tokens), len(self._out))
        if n <= 0:
            return
        sent = self.endpoint.send(bytes(self._out[:n]))
        if sent > 0:
            del self._out[:sent]
            self._tokens -= sent

    def _serve(self) -> None:
        try:
            self._loop()
        except BaseException as exc:  # surfaced to tests through .error
            self.error = exc
            raise

    def _loop(self) -> None:
        core = self.core
        ep = self.endpoint
        last_wall = time.monotonic()
        while not self._stop.is_set():
            wall = time.monotonic()
            lockstep = not self.realtime and core.streaming and ep.connected
            with self._lock:
                if lockstep:
                    core.set_time(core.T_us)  # watchdog only
                elif self.realtime and core.streaming:
                    # The ticks a late loop missed are made first, each at its own time, and only
                    # then what the host sent meanwhile is read: the board's loop kept time.
                    self._sample_due(core, core.T_us + int((wall - last_wall) * 1e6 * self.speed))
                else:
                    core.set_time(core.T_us + int((wall - last_wall) * 1e6 * self.speed))
            last_wall = wall

            # Wait for input, room to write, or the next event.
            wait = DRIVING_WAIT_S if core.driving else IDLE_WAIT_S
            if core.streaming:
                if lockstep and not self._out and self._may_lead(core, wall):
                    wait = 0.0
                elif self.realtime:
                    due = core.next_tick_T_us()
                    wait = min(wait, max(0.0, (due - core.T_us) * 1e-6 / self.speed))
            wfds = ep.write_fds() if self._out else []
            if self._out and self.realtime and self._tokens < 1.0:
                wfds = []  # the UART is still shifting out earlier bytes
                wait = min(wait, max(2e-4, (1.0 - self._tokens) / (BAUD / 10.0 * self.speed)))
            try:
                ready_r, ready_w, _ = select.select(ep.read_fds(), wfds, [], wait)
            except (OSError, ValueError):
                ready_r, _ready_w = [], []
            if ready_r:
                data, new_client = ep.on_readable(ready_r)
                with self._lock:
                    if new_client:
                        self._out.clear()
                        if self.reset_on_connect:
                            core.power_cycle()
                    if data:
                        self._host_frame = (core.T_us, time.monotonic())
                        core.receive(self.link.host_to_board(data))
            with self._lock:
                if core.streaming:
                    if self.realtime:
                        self._sample_due(core)
                    elif ep.connected:
                        now = time.monotonic()
                        while core.streaming and len(self._out) < FAST_BATCH_BYTES and self._may_lead(core, now):
                            core.sample()
            if self._out:
                self._flush()

    def _may_lead(self, core: BoardCore, wall: float) -> bool:
        """Lockstep: whether the next sample may be made now (see the module docstring)."""
        if not core.driving:
            return True
        due = core.next_tick_T_us()
        host_T_us, host_wall = self._host_frame
        return due is None or due <= host_T_us + (LOCKSTEP_LEAD_S + (wall - host_wall) * self.speed) * 1e6

    def _sample_due(self, core: BoardCore, upto_us: int | None = None) -> None:
        """Real time: every tick up to ``upto_us`` (default now), then the clock there
        (BoardCore.run_until). A loop that fell behind (a busy host computer) catches up with the
        right timestamps, and the UART sends what it sent before each tick; beyond
        ``max_catch_up_s`` (device time) the firmware sees the missed ticks at once and counts
        them as overruns."""
        core.run_until(
            core.T_us if upto_us is None else upto_us,
            max_late_us=int(self.max_catch_up_s * 1e6),
            before_tick=lambda due: self._flush_paced(upto_us=due),
        )
