"""ctypes binding of the firmware core's host library (firmware/lib/core/host_api.h).

:class:`FirmwareCore` is one board running the firmware's own dev::Device, model store and
estimator; the Python side only pushes what the hardware presents and collects what the
firmware produces.
"""

from __future__ import annotations

import ctypes as C
import threading

from porosense.firmware.hostlib import library_path

EEPROM_BYTES = 1024
RESET_POWER_ON, RESET_EXTERNAL, RESET_WATCHDOG = 0x01, 0x02, 0x08  # AVR MCUSR bits
REFRESH_FN = C.CFUNCTYPE(None, C.c_void_p, C.c_uint32)
_TAKE_CHUNK = 1 << 16


class State(C.Structure):
    """ps_state: what the firmware drives, read after each call."""

    _fields_ = [
        ("setpoint_dkpa", C.c_int16 * 3),
        ("pump_mask", C.c_uint8),
        ("valve_mask", C.c_uint8),
        ("streaming", C.c_uint8),
        ("power_lost", C.c_uint8),
        ("reset_requested", C.c_uint8),
        ("analog_pin", C.c_uint8),
        ("analog_duty", C.c_uint8),
        ("rate_hz", C.c_uint16),
        ("flags", C.c_uint16),
        ("rx_frames", C.c_uint32),
        ("tx_frames", C.c_uint32),
        ("eeprom_writes", C.c_uint32),
    ]


_lib = None
_lib_lock = threading.Lock()


def load_library() -> C.CDLL:
    """The host library, built on first use (see porosense.firmware.hostlib)."""
    global _lib
    with _lib_lock:
        if _lib is None:
            lib = C.CDLL(str(library_path()))
            P = C.c_void_p
            sig = {
                "ps_create": (P, []),
                "ps_destroy": (None, [P]),
                "ps_boot": (None, [P, C.c_uint8, C.c_uint64]),
                "ps_eeprom": (C.POINTER(C.c_uint8), [P]),
                "ps_set_refresh": (None, [P, REFRESH_FN, P]),
                "ps_set_present": (None, [P, C.c_int, C.c_int]),
                "ps_set_inputs": (None, [P, C.POINTER(C.c_double), C.POINTER(C.c_double)]),
                "ps_set_tx_room": (None, [P, C.c_uint32]),
                "ps_fail_after_writes": (None, [P, C.c_int32, C.c_uint16]),
                "ps_set_time": (None, [P, C.c_uint64]),
                "ps_feed": (C.c_uint32, [P, C.c_char_p, C.c_uint32]),
                "ps_poll": (None, [P]),
                "ps_next_tick": (C.c_int64, [P]),
                "ps_run_to": (C.c_uint32, [P, C.c_uint64]),
                "ps_take": (C.c_uint32, [P, C.c_char_p, C.c_uint32]),
                "ps_state_get": (None, [P, C.POINTER(State)]),
            }
            for name, (res, args) in sig.items():
                fn = getattr(lib, name)
                fn.restype, fn.argtypes = res, args
            _lib = lib
        return _lib


class FirmwareCore:
    """One board: the firmware core in this process. Not thread-safe (callers lock).

    ``refresh(conversion_us)`` is called when the firmware starts an ADC conversion that no
    :meth:`set_inputs` covers; it should push new inputs.
    """

    def __init__(self, refresh=None):
        self._lib = load_library()
        self._h = self._lib.ps_create()
        self._state = State()
        self._buf = C.create_string_buffer(_TAKE_CHUNK)
        self._volts = (C.c_double * 3)()
        self._euler = (C.c_double * 3)()
        self._refresh_py = refresh
        # Kept referenced: the library holds the pointer.
        self._refresh_c = REFRESH_FN(self._on_refresh)
        self._lib.ps_set_refresh(self._h, self._refresh_c, None)
        self.refresh_error: BaseException | None = None

    def _on_refresh(self, _ctx, conversion_us: int) -> None:
        if self._refresh_py is None:
            return
        try:
            self._refresh_py(int(conversion_us))
        except BaseException as exc:  # an exception cannot cross the C frames
            self.refresh_error = exc

    def close(self) -> None:
        if self._h:
            self._lib.ps_destroy(self._h)
            self._h = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # -------------------------------------------------------------- hardware in

    def boot(self, reset_cause: int = RESET_POWER_ON, clock_offset_us: int = 0) -> None:
        self._lib.ps_boot(self._h, reset_cause, int(clock_offset_us))
        self._raise_refresh_error()

    def set_present(self, adc: bool, imu: bool) -> None:
        self._lib.ps_set_present(self._h, int(adc), int(imu))

    def set_inputs(self, volts, euler_deg) -> None:
        """Divider voltages (V, 3) and Euler angles (deg, 3) the chips will report."""
        v, e = self._volts, self._euler
        n = len(volts)
        v[0] = volts[0] if n > 0 else 0.0
        v[1] = volts[1] if n > 1 else 0.0
        v[2] = volts[2] if n > 2 else 0.0
        e[0], e[1], e[2] = euler_deg[0], euler_deg[1], euler_deg[2]
        self._lib.ps_set_inputs(self._h, v, e)

    def set_tx_room(self, room: int) -> None:
        self._lib.ps_set_tx_room(self._h, max(0, int(room)))

    def fail_after_writes(self, n: int | None, first_addr: int = 0) -> None:
        self._lib.ps_fail_after_writes(self._h, -1 if n is None else int(n), int(first_addr))

    def eeprom(self) -> bytes:
        return bytes(C.cast(self._lib.ps_eeprom(self._h), C.POINTER(C.c_uint8 * EEPROM_BYTES)).contents)

    def load_eeprom(self, image: bytes) -> None:
        dst = C.cast(self._lib.ps_eeprom(self._h), C.POINTER(C.c_uint8 * EEPROM_BYTES)).contents
        C.memmove(dst, bytes(image[:EEPROM_BYTES]), min(len(image), EEPROM_BYTES))

    # -------------------------------------------------------------- running

    def set_time(self, t_us: int) -> None:
        self._lib.ps_set_time(self._h, int(t_us))

    def feed(self, data: bytes) -> None:
        self._lib.ps_feed(self._h, data, len(data))

    def poll(self) -> None:
        self._lib.ps_poll(self._h)
        self._raise_refresh_error()

    def next_tick(self) -> int | None:
        t = self._lib.ps_next_tick(self._h)
        return None if t < 0 else t

    def run_to(self, t_us: int) -> int:
        n = self._lib.ps_run_to(self._h, int(t_us))
        self._raise_refresh_error()
        return n

    def take(self) -> bytes:
        out = b""
        while True:
            n = self._lib.ps_take(self._h, self._buf, _TAKE_CHUNK)
            if n == 0:
                return out
            out += self._buf.raw[:n]
            if n < _TAKE_CHUNK:
                return out

    def state(self) -> State:
        self._lib.ps_state_get(self._h, C.byref(self._state))
        return self._state

    def _raise_refresh_error(self) -> None:
        if self.refresh_error is not None:
            exc, self.refresh_error = self.refresh_error, None
            raise exc
