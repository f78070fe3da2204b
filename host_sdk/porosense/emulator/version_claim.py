"""What the emulated board says about itself in HELLO_REPLY: the EMULATED capability, and
for tests of version refusal another protocol version. The firmware's frames are rewritten
on their way to the link; every other byte passes unchanged."""

from __future__ import annotations

from porosense.protocol import FrameError, MsgType, decode_frame, encode_frame
from porosense.protocol._messages import Capability

_HELLO_REPLY = int(MsgType.HELLO_REPLY)
_HELLO_BYTE = bytes((_HELLO_REPLY,))
_CAPS_AT = 5  # HELLO_REPLY: proto_major, proto_minor, fw x3, capabilities (u16)


class HelloRewrite:
    """Adds ``capabilities`` to HELLO_REPLY; with ``version`` (major, minor) also rewrites
    the version byte of every frame and the versions in HELLO_REPLY."""

    def __init__(self, capabilities: int = int(Capability.EMULATED), version: tuple[int, int] | None = None):
        self.capabilities = int(capabilities)
        self.version = version

    def rewrite(self, data: bytes) -> bytes:
        """``data``: whole frames (and text lines) from the firmware."""
        chunks = data.split(b"\x00")
        # In a COBS-encoded frame the type is byte 2 (code byte, version, type: none is zero).
        if self.version is None and not any(c[2:3] == _HELLO_BYTE for c in chunks):
            return data
        return b"\x00".join(self._frame(c) if c else c for c in chunks)

    def _frame(self, chunk: bytes) -> bytes:
        try:
            frame = decode_frame(chunk, accept_any_version=True)
        except FrameError:
            return chunk  # text of the line mode, or not a frame
        payload, version = bytearray(frame.payload), frame.version
        if frame.type == _HELLO_REPLY:
            caps = int.from_bytes(payload[_CAPS_AT : _CAPS_AT + 2], "little") | self.capabilities
            payload[_CAPS_AT : _CAPS_AT + 2] = caps.to_bytes(2, "little")
        if self.version is not None:
            major, minor = self.version
            version = (major << 4) | minor
            if frame.type == _HELLO_REPLY:
                payload[0:2] = bytes((major, minor))
        if frame.type != _HELLO_REPLY and self.version is None:
            return chunk
        return encode_frame(frame.type, frame.seq, bytes(payload), version)[:-1]
