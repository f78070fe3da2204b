"""ctypes binding of the firmware core's host library (firmware/lib/core/host_api.h).

:class:`FirmwareCore` is one board running the firmware's own dev::Device, model store and
estimator in this process: the caller presents what the hardware would (sensor inputs,
received bytes, the clock) and collects what the firmware produced (bytes, outputs).
"""

from __future__ import annotations

import ctypes as C
import threading

from porosense.firmware.hostlib import library_path

EEPROM_BYTES = 1024
RESET_POWER_ON, RESET_EXTERNAL, RESET_WATCHDOG = 0x01, 0x02, 0x08  # AVR MCUSR bits
REFRESH_FN = C.CFUNCTYPE(None, C.c_void_p, C.c_uint32)
_TAKE = 1 << 16
_u8, _u16, _u32 = C.c_uint8, C.c_uint16, C.c_uint32


class State(C.Structure):
    """ps_state: what the firmware drives and counts, read after each call."""

    _fields_ = [
        ("setpoint_dkpa", C.c_int16 * 3),
        ("pump_mask", _u8),
        ("valve_mask", _u8),
        ("streaming", _u8),
        ("power_lost", _u8),
        ("reset_requested", _u8),
        ("analog_pin", _u8),
        ("analog_duty", _u8),
        ("rate_hz", _u16),
        ("flags", _u16),
        ("rx_frames", _u32),
        ("tx_frames", _u32),
        ("eeprom_writes", _u32),
    ]


_lib = None
_lib_lock = threading.Lock()


def load_library() -> C.PyDLL:
    """The host library, built on first use (porosense.firmware.hostlib)."""
    global _lib
    with _lib_lock:
        if _lib is None:
            # PyDLL keeps the GIL during calls: they take microseconds, and releasing the GIL
            # at each of them would let a busy host thread hold it for a whole switch interval.
            lib = C.PyDLL(str(library_path()))
            P, D3, B = C.c_void_p, C.POINTER(C.c_double), C.c_char_p
            for name, res, args in (
                ("ps_create", P, []),
                ("ps_destroy", None, [P]),
                ("ps_boot", None, [P, _u8, C.c_uint64]),
                ("ps_eeprom", C.POINTER(_u8), [P]),
                ("ps_flash_store", C.POINTER(_u8), [P]),
                ("ps_set_refresh", None, [P, REFRESH_FN, P]),
                ("ps_set_present", None, [P, C.c_int, C.c_int]),
                ("ps_set_inputs", None, [P, D3, D3]),
                ("ps_set_tx_room", None, [P, _u32]),
                ("ps_fail_after_writes", None, [P, C.c_int32, _u16]),
                ("ps_set_time", None, [P, C.c_uint64]),
                ("ps_feed", _u32, [P, B, _u32]),
                ("ps_poll", None, [P]),
                ("ps_next_tick", C.c_int64, [P]),
                ("ps_run_to", _u32, [P, C.c_uint64]),
                ("ps_step", _u32, [P, C.c_uint64, D3, D3, _u32, B, _u32, C.POINTER(_u32), C.POINTER(State)]),
                ("ps_take", _u32, [P, B, _u32]),
                ("ps_state_get", None, [P, C.POINTER(State)]),
            ):
                fn = getattr(lib, name)
                fn.restype, fn.argtypes = res, args
            _lib = lib
        return _lib


class FirmwareCore:
    """One board: the firmware core in this process (not thread-safe: callers lock).

    ``refresh(conversion_us)`` is called when the firmware starts an ADC conversion that no
    presented input covers (R0 calibration averages many); it should call :meth:`set_inputs`.
    """

    def __init__(self, refresh=None):
        self._lib = load_library()
        self._h = self._lib.ps_create()
        self.state = State()  # refreshed by every call that runs firmware code
        self._buf = C.create_string_buffer(_TAKE)
        self._n = _u32()
        self._volts, self._euler = (C.c_double * 3)(), (C.c_double * 3)()
        self._refresh_py = refresh
        self._refresh_c = REFRESH_FN(self._on_refresh)  # referenced: the library keeps the pointer
        self._lib.ps_set_refresh(self._h, self._refresh_c, None)
        self._error: BaseException | None = None

    def _on_refresh(self, _ctx, conversion_us: int) -> None:
        try:
            if self._refresh_py is not None:
                self._refresh_py(int(conversion_us))
        except BaseException as exc:  # cannot cross the C frames: raised after the call
            self._error = exc

    def _done(self) -> None:
        self._lib.ps_state_get(self._h, C.byref(self.state))
        if self._error is not None:
            exc, self._error = self._error, None
            raise exc

    def __del__(self):
        if getattr(self, "_h", None):
            self._lib.ps_destroy(self._h)
            self._h = None

    def boot(self, reset_cause: int = RESET_POWER_ON, clock_offset_us: int = 0) -> None:
        """Power-on or reset: RAM lost, EEPROM kept; the device clock starts at the offset."""
        self._lib.ps_boot(self._h, reset_cause, int(clock_offset_us))
        self._done()

    def set_present(self, adc: bool, imu: bool) -> None:
        self._lib.ps_set_present(self._h, int(adc), int(imu))

    def _inputs(self, volts, euler_deg) -> None:
        v, e, n = self._volts, self._euler, len(volts)
        v[0], v[1], v[2] = (volts[0] if n > 0 else 0.0), (volts[1] if n > 1 else 0.0), (volts[2] if n > 2 else 0.0)
        e[0], e[1], e[2] = euler_deg[0], euler_deg[1], euler_deg[2]

    def set_inputs(self, volts, euler_deg) -> None:
        """Divider voltages (V, up to 3) and Euler angles (deg, 3) the chips will report."""
        self._inputs(volts, euler_deg)
        self._lib.ps_set_inputs(self._h, self._volts, self._euler)

    def fail_after_writes(self, n: int | None, first_addr: int = 0) -> None:
        """Cut the power after ``n`` more EEPROM byte writes at ``first_addr`` or above."""
        self._lib.ps_fail_after_writes(self._h, -1 if n is None else int(n), int(first_addr))

    def eeprom(self) -> bytes:
        return bytes(C.cast(self._lib.ps_eeprom(self._h), C.POINTER(_u8 * EEPROM_BYTES)).contents)

    def program_flash(self, pages, n_pages: int | None = None) -> int:
        """Write (flash address, bytes) pages into the flash model store as an upload would,
        stopping after ``n_pages`` (a torn upload); the caller reboots. Returns pages written."""
        from porosense.protocol.model_layout import FLASH_BASE, FLASH_SLOT_SIZE, FLASH_SLOTS

        size = FLASH_SLOTS * FLASH_SLOT_SIZE
        mem = C.cast(self._lib.ps_flash_store(self._h), C.POINTER(_u8 * size)).contents
        done = 0
        for addr, data in list(pages)[:n_pages]:
            off = addr - FLASH_BASE
            if off < 0 or off + len(data) > size:
                raise ValueError(f"page 0x{addr:04X} is outside the flash model store")
            mem[off : off + len(data)] = data
            done += 1
        return done

    def flash_store(self) -> bytes:
        """The flash model store's bytes (from layout.FLASH_BASE)."""
        from porosense.protocol.model_layout import FLASH_SLOT_SIZE, FLASH_SLOTS

        return bytes(
            C.cast(self._lib.ps_flash_store(self._h), C.POINTER(_u8 * (FLASH_SLOTS * FLASH_SLOT_SIZE))).contents
        )

    def set_time(self, t_us: int) -> None:
        """Device time (us since power-on); runs no firmware code."""
        self._lib.ps_set_time(self._h, int(t_us))

    def receive(self, data: bytes, tx_room: int) -> bytes:
        """Queue received bytes, run the main loop; what the firmware sent."""
        self._lib.ps_feed(self._h, data, len(data))
        self._lib.ps_set_tx_room(self._h, max(0, int(tx_room)))
        self._lib.ps_poll(self._h)
        self._done()
        return self.take()

    def next_tick(self) -> int | None:
        """Device time (us) of the next sample tick, None when not streaming."""
        t = self._lib.ps_next_tick(self._h)
        return None if t < 0 else t

    def step(self, t_us: int, volts, euler_deg, tx_room: int) -> tuple[int, bytes]:
        """Present the inputs, run the clock to ``t_us`` and the main loop: (ticks, bytes sent)."""
        self._inputs(volts, euler_deg)
        ticks = self._lib.ps_step(
            self._h,
            int(t_us),
            self._volts,
            self._euler,
            max(0, int(tx_room)),
            self._buf,
            _TAKE,
            C.byref(self._n),
            C.byref(self.state),
        )
        if self._error is not None:
            self._done()
        n = self._n.value
        return ticks, (self._buf.raw[:n] + self.take() if n == _TAKE else self._buf.raw[:n])

    def take(self) -> bytes:
        """Bytes the firmware sent since the last take."""
        out = b""
        while n := self._lib.ps_take(self._h, self._buf, _TAKE):
            out += self._buf.raw[:n]
        return out
