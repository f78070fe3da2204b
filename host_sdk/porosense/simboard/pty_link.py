"""The simboard's UART on a pseudo-terminal, as a USB-serial Uno appears to the host: a device
path that avrdude and pyserial open like /dev/ttyACM0, and opening it resets the board (the
Uno's DTR auto-reset), so that avrdude -c arduino finds Optiboot listening.

    with SimBoard(bootloader=optiboot_hex, max_speed=1.0) as board, PtyLink(board) as pty:
        subprocess.run(["avrdude", "-p", "atmega328p", "-c", "arduino", "-P", pty.path, ...])

The link relays bytes between the pty's master side and the harness's TCP socket in a thread.
An open of the device side shows as the master's hang-up ending (Linux reports POLLHUP on the
master while no process holds the device side open).
"""

from __future__ import annotations

import os
import select
import socket
import threading
import time
from urllib.parse import urlparse

from porosense.errors import DeviceError


class PtyLink:
    """Relay between a pseudo-terminal (``path``) and the simboard's UART; ``resets`` counts the
    resets made by opens of ``path`` (with ``reset_on_open``)."""

    def __init__(self, board, reset_on_open: bool = True) -> None:
        self.board = board
        self.reset_on_open = reset_on_open
        self.resets = 0
        self._master, slave = os.openpty()
        self.path = os.ttyname(slave)
        os.close(slave)  # only the user's opens hold the device side
        url = urlparse(board.url)
        try:
            self._sock = socket.create_connection((url.hostname, url.port), timeout=5.0)
        except OSError as exc:
            os.close(self._master)
            raise DeviceError(f"simboard UART at {board.url}: {exc}") from None
        self._sock.setblocking(False)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._relay, name="simboard-pty", daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        poll = select.poll()
        poll.register(self._master, select.POLLIN)
        poll.register(self._sock, select.POLLIN)
        hung_up = True
        while not self._stop.is_set():
            events = dict(poll.poll(20))
            m_ev = events.get(self._master, 0)
            if m_ev & select.POLLHUP and not m_ev & select.POLLIN:
                hung_up = True
                time.sleep(0.002)  # nobody holds the device side: POLLHUP stays set
            elif hung_up:
                hung_up = False  # the device side was opened: the Uno's DTR resets the board
                if self.reset_on_open:
                    self.board.reset(wait=False)
                    self.resets += 1
            if m_ev & select.POLLIN:
                try:
                    data = os.read(self._master, 4096)
                except OSError:
                    data = b""
                if data:
                    self._sock.sendall(data)
            if events.get(self._sock.fileno(), 0) & select.POLLIN:
                try:
                    data = self._sock.recv(4096)
                except BlockingIOError:
                    data = b""
                if data and not hung_up:
                    os.write(self._master, data)  # what nobody reads is lost, as on a serial line

    def close(self) -> None:
        """Stop relaying; the pty and the socket close."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self._sock.close()
        os.close(self._master)

    def __enter__(self) -> PtyLink:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
