"""Where the emulated board's UART comes out: a TCP port (socket://) or a pseudo-terminal."""

from __future__ import annotations

import errno
import os
import socket

from porosense.errors import InputError

# A small kernel send buffer keeps the board from running far ahead of a slow reader.
SEND_BUFFER_BYTES = 8192


class TcpEndpoint:
    """Listens on host:port (0 picks a free port); one client at a time, a new one replaces it."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0):
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host, port))
        except OSError as exc:
            self._listener.close()
            raise InputError(f"cannot listen on {host}:{port}: {exc.strerror}") from None
        self._listener.listen(1)
        self._listener.setblocking(False)
        self.host, self.port = self._listener.getsockname()[:2]
        self.client: socket.socket | None = None
        self.connections = 0

    @property
    def url(self) -> str:
        return f"socket://{self.host}:{self.port}"

    @property
    def connected(self) -> bool:
        return self.client is not None

    def read_fds(self) -> list:
        return [self._listener] + ([self.client] if self.client else [])

    def write_fds(self) -> list:
        return [self.client] if self.client else []

    def on_readable(self, ready) -> tuple[bytes, bool]:
        """(bytes received, True when a new client connected)."""
        new_client = False
        if self._listener in ready:
            try:
                conn, _ = self._listener.accept()
            except OSError:
                conn = None
            if conn is not None:
                if self.client:
                    self.client.close()
                conn.setblocking(False)
                conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                conn.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
                self.client = conn
                self.connections += 1
                new_client = True
        data = b""
        if self.client and self.client in ready:
            try:
                data = self.client.recv(65536)
                if not data:
                    self._drop_client()
            except BlockingIOError:
                pass
            except OSError:
                self._drop_client()
        return data, new_client

    def send(self, data: bytes) -> int:
        """Bytes accepted by the kernel (0 when it is full or nobody listens)."""
        if not self.client:
            return len(data)  # nobody connected: the bytes go nowhere, like an unplugged cable
        try:
            return self.client.send(data)
        except BlockingIOError:
            return 0
        except OSError:
            self._drop_client()
            return len(data)

    def _drop_client(self) -> None:
        if self.client:
            self.client.close()
        self.client = None

    def close(self) -> None:
        self._drop_client()
        self._listener.close()


class PtyEndpoint:
    """A pseudo-terminal: the board holds the master, hosts open the slave path (/dev/pts/N)."""

    def __init__(self):
        import tty

        if not hasattr(os, "openpty"):
            raise InputError("pseudo-terminals are not available on this system; use tcp://")
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self.connections = 0

    @property
    def url(self) -> str:
        return self.path

    @property
    def connected(self) -> bool:
        return True

    def read_fds(self) -> list:
        return [self._master]

    def write_fds(self) -> list:
        return [self._master]

    def on_readable(self, ready) -> tuple[bytes, bool]:
        if self._master not in ready:
            return b"", False
        try:
            return os.read(self._master, 65536), False
        except BlockingIOError:
            return b"", False
        except OSError as exc:
            if exc.errno == errno.EIO:  # no process has the slave open
                return b"", False
            raise

    def send(self, data: bytes) -> int:
        try:
            return os.write(self._master, data)
        except BlockingIOError:
            return 0
        except OSError as exc:
            if exc.errno == errno.EIO:
                return len(data)
            raise

    def close(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


def make_endpoint(listen: str):
    """Endpoint for ``tcp://HOST:PORT`` (PORT 0 picks one) or ``pty``."""
    if listen == "pty":
        return PtyEndpoint()
    if listen.startswith("tcp://"):
        hostport = listen[len("tcp://") :]
        host, _, port = hostport.rpartition(":")
        try:
            return TcpEndpoint(host or "127.0.0.1", int(port))
        except ValueError:
            raise InputError(f"bad port in {listen!r}; expected tcp://HOST:PORT") from None
    raise InputError(f"cannot listen on {listen!r}; use tcp://127.0.0.1:PORT or pty")
