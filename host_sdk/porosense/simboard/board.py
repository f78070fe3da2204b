"""SimBoard: the real firmware ELF on a simulated Uno, its sensors fed by a plant in lock-step.

>>> with SimBoard(Path("firmware/build/porosense.elf")) as board:   # doctest: +SKIP
...     dev = serial.serial_for_url(board.url)                       # socket://127.0.0.1:PORT
"""

from __future__ import annotations

import collections
import select
import shutil
import subprocess
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from porosense.errors import DeviceError
from porosense.firmware.files import elf_path
from porosense.firmware.files import harness_path as packaged_harness
from porosense.simboard import link
from porosense.simboard.plants import default_plant

DEFAULT_ELF = elf_path()
_START_TIMEOUT_S = 10.0


def harness_path() -> Path:
    """The harness binary: $POROSENSE_SIMBOARD, else the packaged one (porosense.firmware)."""
    return packaged_harness()


@dataclass(frozen=True)
class PinState:
    """Outputs of the board at one tick: pumps (D2, D4, D7), valves (D8, D12, D13), the
    regulator duties on D5, D6, D9 (0..255) and the vacuum setpoints they stand for (kPa)."""

    time_s: float
    pumps: tuple[bool, bool, bool]
    valves: tuple[bool, bool, bool]
    regulator_duty: tuple[int, int, int]
    setpoint_kpa: tuple[float, float, float]
    level: int  # bit n: Dn driven high
    pwm_duty: dict  # Arduino PWM pin -> 0..255

    @classmethod
    def from_tick(cls, t: link.Tick) -> PinState:
        duty = dict(zip(link.PWM_PINS, t.duty))
        reg = tuple(duty[p] for p in link.REGULATOR_PINS)
        return cls(
            time_s=t.time_s,
            pumps=tuple(bool(t.pins >> p & 1) for p in link.PUMP_PINS),
            valves=tuple(bool(t.pins >> p & 1) for p in link.VALVE_PINS),
            regulator_duty=reg,
            setpoint_kpa=tuple(d / 255.0 * link.FULL_SCALE_KPA for d in reg),
            level=t.pins,
            pwm_duty=duty,
        )


class SimBoard:
    """The firmware ``elf`` running in the simboard harness with a plant in lock-step.

    ``actuator``, ``porosity``, ``load_g``, ``seed`` and ``effects`` select the simulator plant
    (porosense.sim.make_plant); ``plant`` replaces it with any object of the same interface.
    ``eeprom``: an image file loaded at start (if present) and written at close, so a later
    board "keeps its model"; None uses a temporary image. ``absent``: sensors that never
    acknowledge ("ads", "bno"). ``period_ms``: plant step in AVR time. ``max_speed``: cap on
    the speed relative to real time (None: as fast as possible). ``truth_every_ms``: spacing
    of the ground-truth log in AVR time. ``reset_on_connect``: reset the AVR whenever a
    client opens the serial URL, as the Uno's DTR line does on a real port.
    """

    def __init__(
        self,
        elf: Path | str = DEFAULT_ELF,
        actuator: str = "contractor",
        porosity=None,
        seed: int = 0,
        eeprom: Path | str | None = None,
        *,
        load_g: float = 0.0,
        effects=None,
        plant=None,
        absent=(),
        period_ms: float = 1.0,
        max_speed: float | None = None,
        bno_boot_ms: float = 0.0,
        truth_every_ms: float = 10.0,
        port: int = 0,
        reset_on_connect: bool = False,
        harness: Path | str | None = None,
        bootloader: Path | str | None = None,
    ):
        # elf None with a bootloader: a blank application flash, for an upload through it.
        self.elf = Path(elf) if elf is not None else None
        self.bootloader = Path(bootloader) if bootloader is not None else None
        self.harness = Path(harness) if harness else harness_path()
        if not self.harness.is_file():
            raise DeviceError(f"simboard harness not found at {self.harness}: build it with `make -C tools/simboard`")
        if self.elf is None and self.bootloader is None:
            raise DeviceError("simboard: give a firmware ELF, a bootloader, or both")
        if self.elf is not None and not self.elf.is_file():
            raise DeviceError(f"firmware ELF not found at {self.elf}: build it with `make -C firmware`")
        if self.bootloader is not None and not self.bootloader.is_file():
            raise DeviceError(f"bootloader HEX not found at {self.bootloader}")
        self._tmpdir = None
        self.eeprom_path = Path(eeprom) if eeprom is not None else None  # None: a temporary image
        if self.eeprom_path is not None and not self.eeprom_path.parent.is_dir():
            raise DeviceError(f"EEPROM image folder {self.eeprom_path.parent} does not exist")
        self.plant = (
            plant
            if plant is not None
            else default_plant(actuator, porosity=porosity, load_g=load_g, seed=seed, effects=effects)
        )
        self.actuator = actuator
        self.period_ms = float(period_ms)
        self._absent_mask = _absent_mask(absent)
        self._args = [
            str(self.harness),
            *(["--elf", str(self.elf)] if self.elf is not None else []),
            *(["--bootloader", str(self.bootloader)] if self.bootloader is not None else []),
            "--cosim",
            "--port",
            str(port),
            "--period-us",
            f"{self.period_ms * 1000.0:g}",
            "--bno-boot-ms",
            f"{bno_boot_ms:g}",
        ]
        if max_speed:
            self._args += ["--max-speed", f"{max_speed:g}"]
        if reset_on_connect:
            self._args.append("--reset-on-connect")
        if self._absent_mask:
            self._args += ["--absent", ",".join(n for n, b in (("ads", 1), ("bno", 2)) if self._absent_mask & b)]
        self._truth_every = max(1, round(truth_every_ms / self.period_ms))
        self._proc = None
        self._thread = None
        self._cond = threading.Condition()
        self._commands = collections.deque()
        self._scheduled = []  # (time_s, cmd, arg8, arg16), time-ordered
        self._tick = None
        self._saves = 0
        self._error = None
        self._closed = False
        self.truth: list[dict] = []
        self.last_reset_s = 0.0  # AVR time (since power-on) of the latest reset
        self.port = None
        self.halted = False

    # --- life cycle ---------------------------------------------------------------------
    def __enter__(self) -> SimBoard:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> SimBoard:
        """Starts the harness and the plant loop; returns once the UART port is listening."""
        if self.eeprom_path is None:
            self._tmpdir = tempfile.mkdtemp(prefix="simboard-")
            self.eeprom_path = Path(self._tmpdir) / "eeprom.bin"
        self._stderr = tempfile.TemporaryFile()
        self._pages_path = Path(tempfile.mkdtemp(prefix="simboard-flash-")) / "pages.bin"
        self._proc = subprocess.Popen(
            self._args + ["--eeprom", str(self.eeprom_path), "--flash-pages", str(self._pages_path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
        )
        ready, _, _ = select.select([self._proc.stdout], [], [], _START_TIMEOUT_S)
        line = self._proc.stdout.readline() if ready else b""
        if not line.startswith(b"SIMBOARD 1 PORT "):
            self._proc.kill()
            self._proc.wait()
            if self._tmpdir:
                shutil.rmtree(self._tmpdir, ignore_errors=True)
            text = self._stderr_text()
            ours = [ln for ln in text.splitlines() if ln.startswith("simboard:")]
            raise DeviceError(f"simboard harness did not start: {' '.join(ours) or text or 'no output'}")
        self.port = int(line.split()[3])
        self._wall_start = time.monotonic()
        self._thread = threading.Thread(target=self._loop, name="simboard-plant", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stops the harness (the EEPROM image is written) and the plant loop."""
        if self._closed or self._proc is None:
            return
        self._closed = True
        with self._cond:
            self._commands.append((link.CMD_QUIT, 0, 0))
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._thread.join(timeout=10)
        self.wall_s = time.monotonic() - self._wall_start
        self.log = self._stderr_text()
        self._stderr.close()
        if self._tmpdir:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
        shutil.rmtree(self._pages_path.parent, ignore_errors=True)
        if self._error is not None:
            raise DeviceError(f"simboard plant loop failed: {self._error!r}") from self._error

    # --- the plant loop -----------------------------------------------------------------
    def _loop(self) -> None:
        rd, wr = self._proc.stdout, self._proc.stdin
        ain, euler = np.zeros(4), np.zeros(3)
        last_cycles = 0
        try:
            while True:
                raw = rd.read(link.TICK.size)
                if len(raw) < link.TICK.size:
                    break
                tick = link.Tick.unpack(raw)
                pins = PinState.from_tick(tick)
                dt = (tick.cycles - last_cycles) / link.FREQUENCY_HZ
                last_cycles = tick.cycles
                if dt > 0:
                    reading = self.plant.step(
                        dt, np.array(pins.setpoint_kpa), np.array(pins.pumps, float), np.array(pins.valves, float)
                    )
                    ain[:3] = np.asarray(reading.voltage_V, float)[:3]
                    euler[:] = np.asarray(reading.euler_deg, float)[:3]
                    if tick.seq % self._truth_every == 0:
                        self.truth.append(_truth_row(pins, ain, euler, reading.truth))
                # published before the reply: the harness forwards UART bytes only after it
                with self._cond:
                    self._tick = tick
                    if tick.events & link.EV_RESET:  # the firmware's clocks restart here
                        self.last_reset_s = tick.time_s
                    self._saves += bool(tick.events & link.EV_EEPROM_SAVED)
                    self.halted = bool(tick.events & link.EV_HALTED)
                    self._cond.notify_all()
                cmd = self._next_command(tick.time_s)
                wr.write(link.pack_reply(ain, euler, *cmd))
                wr.flush()
                if cmd[0] == link.CMD_QUIT:
                    break
        except (BrokenPipeError, ValueError, OSError) as e:
            if not self._closed:
                self._error = e
        except Exception as e:  # the plant failed: stop the harness, report at close
            self._error = e
        finally:
            try:
                wr.close()
            except OSError:
                pass
            with self._cond:
                self._cond.notify_all()

    def _next_command(self, now_s: float) -> tuple[int, int, int]:
        with self._cond:
            if self._scheduled and self._scheduled[0][0] <= now_s:
                return self._scheduled.pop(0)[1:]
            if self._commands:
                return self._commands.popleft()
        return (link.CMD_NONE, 0, 0)

    def _command(self, cmd: int, arg8: int = 0, arg16: int = 0) -> None:
        with self._cond:
            self._commands.append((cmd, arg8, arg16))

    def _stderr_text(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read().decode(errors="replace").strip()

    def _check(self) -> None:
        if self._proc is None:
            raise DeviceError("simboard not started: use it as a context manager or call start()")
        if self._error is not None:
            raise DeviceError(f"simboard plant loop failed: {self._error!r}")

    # --- observation --------------------------------------------------------------------
    @property
    def url(self) -> str:
        """pyserial URL of UART0."""
        self._check()
        return f"socket://127.0.0.1:{self.port}"

    def _latest(self) -> link.Tick:
        self.wait_for(lambda t: True, timeout=_START_TIMEOUT_S)
        return self._tick

    @property
    def cycles(self) -> int:
        """AVR cycles since power-on (16 MHz)."""
        return self._latest().cycles

    @property
    def sim_time_s(self) -> float:
        """AVR time since power-on (s)."""
        return self._latest().time_s

    @property
    def pins(self) -> PinState:
        """Pump, valve and regulator outputs at the latest tick."""
        return PinState.from_tick(self._latest())

    @property
    def counters(self) -> dict:
        """Harness counters: resets, UART bytes, EEPROM writes, TWI NACKs, ADC conversions."""
        t = self._latest()
        return {
            k: getattr(t, k)
            for k in ("resets", "twi_nacks", "uart_rx", "uart_tx", "eeprom_writes", "uart_dropped", "adc_conversions")
        }

    @property
    def speed_ratio(self) -> float:
        """AVR time simulated per second of wall time since start."""
        wall = time.monotonic() - self._wall_start
        return self.sim_time_s / wall if wall > 0 else 0.0

    def wait_for(self, predicate, timeout: float = 30.0) -> link.Tick:
        """Blocks until ``predicate(tick)`` holds for a new tick; DeviceError after ``timeout`` s wall."""
        self._check()
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                if self._tick is not None and predicate(self._tick):
                    return self._tick
                if self._error is not None or not self._thread.is_alive():
                    raise DeviceError(f"simboard stopped: {self._error or self._stderr_text()}")
                left = deadline - time.monotonic()
                if left <= 0:
                    raise DeviceError(f"simboard: condition not reached within {timeout} s")
                self._cond.wait(min(left, 0.5))

    def run_for(self, seconds: float, timeout: float = 60.0) -> float:
        """Waits until ``seconds`` more of AVR time have passed; returns the AVR time (s)."""
        end = self.sim_time_s + seconds
        return self.wait_for(lambda t: t.time_s >= end, timeout).time_s

    # --- actions ------------------------------------------------------------------------
    def reset(self, at_s: float | None = None, wait: bool = True) -> None:
        """Resets the AVR (the reset button) now, or when AVR time reaches ``at_s`` seconds.
        The sensors keep running and the EEPROM keeps its contents."""
        self._check()
        before = self._latest().resets
        if at_s is None:
            self._command(link.CMD_RESET)
        else:
            with self._cond:
                self._scheduled.append((float(at_s), link.CMD_RESET, 0, 0))
                self._scheduled.sort()
        if wait:
            self.wait_for(
                lambda t: t.resets != before, timeout=_START_TIMEOUT_S + (max(0.0, (at_s or 0) - self.sim_time_s) * 50)
            )

    def program_flash(self, pages, n_pages: int | None = None) -> None:
        """An upload through the bootloader: writes (flash address, 128 bytes) pages into the
        AVR's flash in order and resets it, as avrdude -D and Optiboot do. ``n_pages`` stops
        after that many pages (a torn upload). Returns once the AVR has restarted."""
        self._check()
        pages = list(pages)
        with open(self._pages_path, "wb") as f:
            for addr, data in pages:
                if len(data) != link.FLASH_PAGE or addr % link.FLASH_PAGE:
                    raise ValueError(f"page 0x{addr:04X}: whole {link.FLASH_PAGE}-byte pages only")
                f.write(int(addr).to_bytes(4, "little") + bytes(data))
        n = len(pages) if n_pages is None else max(0, min(int(n_pages), len(pages)))
        before = self._latest().resets
        self._command(link.CMD_PROGRAM_FLASH, 0, n)
        tick = self.wait_for(lambda t: t.resets != before or t.events & link.EV_FAULT, timeout=_START_TIMEOUT_S)
        if tick.resets == before:
            raise DeviceError("simboard: the flash pages could not be programmed (outside the application flash?)")

    def power_cycle(self) -> None:
        """Resets the AVR and both sensors (the BNO055 boots again)."""
        before = self._latest().resets
        self._command(link.CMD_POWER_CYCLE)
        self.wait_for(lambda t: t.resets != before)

    def reset_after_eeprom_writes(self, n: int) -> None:
        """Arms a reset right after the firmware has started ``n`` more EEPROM byte writes
        (a torn write); ``n = 0`` disarms."""
        if not 0 <= n <= 0xFFFF:
            raise ValueError("n must be in 0..65535")
        self._command(link.CMD_RESET_AFTER_EE, 0, n)

    def set_absent(self, ads: bool = False, bno: bool = False) -> None:
        """Disconnects (True) or reconnects (False) the ADS1115 and the BNO055."""
        self._command(link.CMD_SET_ABSENT, int(ads) | int(bno) << 1)
        target = self._latest().seq + 2
        self.wait_for(lambda t: t.seq >= target)

    def save_eeprom(self) -> Path:
        """Writes the EEPROM image file now and returns its path."""
        with self._cond:
            saves = self._saves
        self._command(link.CMD_SAVE_EEPROM)
        self.wait_for(lambda t: self._saves > saves)
        return self.eeprom_path

    def eeprom_image(self) -> bytes:
        """The 1024 bytes of EEPROM as they are now."""
        return self.save_eeprom().read_bytes()

    def truth_columns(self) -> dict[str, np.ndarray]:
        """The ground-truth log as columns (one array per key)."""
        rows = list(self.truth)
        return {k: np.array([r[k] for r in rows]) for k in (rows[0] if rows else {})}

    def stats(self) -> dict:
        """AVR time, cycles, wall time, speed ratio and counters."""
        t = self._latest()
        wall = time.monotonic() - self._wall_start
        return {
            "sim_time_s": t.time_s,
            "cycles": t.cycles,
            "wall_s": wall,
            "speed_ratio": t.time_s / wall if wall > 0 else 0.0,
            **self.counters,
        }


@dataclass(frozen=True)
class SpeedReport:
    """AVR time simulated against wall time for one firmware and plant."""

    elf: str
    sim_time_s: float
    wall_s: float
    cycles: int

    @property
    def ratio(self) -> float:
        """Seconds of AVR time per second of wall time (> 1: faster than real time)."""
        return self.sim_time_s / self.wall_s if self.wall_s > 0 else 0.0

    def to_dict(self) -> dict:
        return {**asdict(self), "ratio": self.ratio}

    def __str__(self) -> str:
        return (
            f"simboard: {self.sim_time_s:.2f} s of AVR time ({self.cycles} cycles) in "
            f"{self.wall_s:.2f} s wall: {self.ratio:.2f} x real time"
        )


def measure_speed(elf: Path | str = DEFAULT_ELF, seconds: float = 2.0, **board_args) -> SpeedReport:
    """Runs ``elf`` on a SimBoard for ``seconds`` of AVR time (plant in lock-step, no host
    traffic) and reports the speed relative to real time."""
    with SimBoard(elf, **board_args) as board:
        start_s = board.sim_time_s
        wall0 = time.monotonic()
        # From the same reading: the board runs on while this thread looks (run_for would read
        # the clock again, and a busy host computer lets it move in between).
        end_s = board.wait_for(lambda t: t.time_s >= start_s + seconds, timeout=max(60.0, seconds * 20)).time_s
        wall = time.monotonic() - wall0
        cycles = board.cycles
    return SpeedReport(str(elf), end_s - start_s, wall, cycles)


def _absent_mask(absent) -> int:
    names = {"ads": 1, "ads1115": 1, "bno": 2, "bno055": 2}
    mask = 0
    for name in absent:
        if name not in names:
            raise ValueError(f"unknown sensor {name!r}: use 'ads' or 'bno'")
        mask |= names[name]
    return mask


def _truth_row(pins: PinState, ain, euler, truth: dict) -> dict:
    row = {"t": pins.time_s}
    for i in range(3):
        row[f"pump_{i}"] = pins.pumps[i]
        row[f"valve_{i}"] = pins.valves[i]
        row[f"p_cmd_{i}"] = pins.setpoint_kpa[i]
        row[f"v_{i}"] = float(ain[i])
    row["heading"], row["roll"], row["pitch"] = (float(a) for a in euler)
    for k, v in truth.items():
        arr = np.asarray(v, dtype=float)
        if arr.ndim == 0:
            row[k] = float(arr)
        else:
            for i, x in enumerate(arr.ravel()):
                row[f"{k}_{i}"] = float(x)
    return row
