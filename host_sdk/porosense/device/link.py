"""The byte link under a Device: any pyserial URL, read without blocking, waited on with select.

pyserial's socket:// ``read(n)`` waits for all ``n`` bytes, so the port is kept non-blocking
(timeout 0) and waiting is done here: ``select`` on the port's file descriptor where there is
one, short sleeps otherwise (loop://, Windows).
"""

from __future__ import annotations

import select
import time

from porosense.errors import DeviceError


class SerialLink:
    """Non-blocking reads and writes on an open pyserial port."""

    def __init__(self, port, url: str):
        self.port = port
        self.url = url
        try:
            self._fd = port.fileno()
        except Exception:  # loop://, Windows: no descriptor to select on
            self._fd = None

    @classmethod
    def open(cls, url: str, baudrate: int = 115200) -> SerialLink:
        """Open ``url`` (/dev/ttyACM0, COM3, socket://host:port, loop://) non-blocking."""
        import serial

        try:
            port = serial.serial_for_url(url, baudrate=baudrate, timeout=0, write_timeout=2.0)
        except (serial.SerialException, ValueError, OSError) as exc:
            raise DeviceError(f"cannot open {url}: {exc}") from None
        return cls(port, url)

    def write(self, data: bytes) -> None:
        """Send ``data`` (DeviceError when the link is gone)."""
        try:
            self.port.write(data)
        except Exception as exc:
            raise DeviceError(f"write to {self.url} failed: {exc}") from None

    def read(self, wait_s: float) -> bytes:
        """Bytes available now, waiting up to ``wait_s`` seconds for the first one."""
        try:
            data = self.port.read(65536)
            if data or wait_s <= 0:
                return data
            if self._fd is not None:
                ready, _, _ = select.select([self._fd], [], [], wait_s)
                return self.port.read(65536) if ready else b""
            end = time.monotonic() + wait_s
            while time.monotonic() < end:
                time.sleep(min(0.001, wait_s))
                data = self.port.read(65536)
                if data:
                    return data
            return b""
        except DeviceError:
            raise
        except Exception as exc:
            raise DeviceError(f"read from {self.url} failed: {exc}") from None

    def discard_input(self) -> None:
        """Drop whatever the link holds (stale bytes from before the handshake)."""
        try:
            self.port.reset_input_buffer()
        except Exception:
            pass
        while self.read(0):
            pass

    def close(self) -> None:
        try:
            self.port.close()
        except Exception:
            pass
