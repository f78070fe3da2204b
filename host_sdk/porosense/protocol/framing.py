"""Frames of the wire protocol: COBS(header | payload | crc) followed by one 0x00.

header = version (u8), type (u8), sequence (u8), payload length (u8); crc is
CRC-16/MCRF4XX over header and payload, low byte first. See protocol/spec.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import crcmod.predefined
from cobs import cobs

from porosense.protocol._messages import MAX_PAYLOAD, MESSAGES, VERSION_BYTE, MsgType

HEADER_LEN = 4
CRC_LEN = 2
DELIMITER = b"\x00"
# COBS adds one byte per 254 and one overhead byte; plus the delimiter.
MAX_FRAME_LEN = HEADER_LEN + MAX_PAYLOAD + CRC_LEN + 2 + 1

_crc16 = crcmod.predefined.mkCrcFun("crc-16-mcrf4xx")


def crc16(data: bytes) -> int:
    """CRC-16/MCRF4XX of ``data`` (poly 0x1021 reflected, init 0xFFFF); b"123456789" -> 0x6F91."""
    return _crc16(data)


@dataclass(frozen=True)
class Frame:
    """One decoded frame: the raw header fields and payload bytes."""

    type: int
    seq: int
    payload: bytes
    version: int = VERSION_BYTE

    def message(self):
        """The payload as its generated message class (``ValueError`` on a bad length)."""
        cls = MESSAGES.get(self.type)
        if cls is None:
            raise ValueError(f"unknown message type 0x{self.type:02X}")
        return cls.unpack(self.payload)

    @property
    def name(self) -> str:
        try:
            return MsgType(self.type).name
        except ValueError:
            return f"0x{self.type:02X}"


def encode_frame(msg_type: int, seq: int, payload: bytes = b"", version: int = VERSION_BYTE) -> bytes:
    """Encode one frame, delimiter included."""
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = bytes((version & 0xFF, msg_type & 0xFF, seq & 0xFF, len(payload))) + bytes(payload)
    crc = crc16(body)
    return cobs.encode(body + bytes((crc & 0xFF, crc >> 8))) + DELIMITER


def encode_message(message, seq: int, version: int = VERSION_BYTE) -> bytes:
    """Encode a generated message object as a frame."""
    return encode_frame(message.TYPE, seq, message.pack(), version)


class FrameError(ValueError):
    """Why a frame was dropped; ``reason`` is one of the counters of FrameDecoder."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


def decode_frame(encoded: bytes, accept_any_version: bool = False) -> Frame:
    """Decode one frame (COBS body without the delimiter); raise FrameError if it is bad."""
    try:
        body = cobs.decode(bytes(encoded))
    except cobs.DecodeError as exc:
        raise FrameError("bad_cobs", str(exc)) from None
    if len(body) < HEADER_LEN + CRC_LEN:
        raise FrameError("bad_length", f"{len(body)} bytes is shorter than header and CRC")
    crc = body[-2] | (body[-1] << 8)
    if crc16(body[:-2]) != crc:
        raise FrameError("bad_crc", f"crc 0x{crc:04X} does not match")
    version, msg_type, seq, length = body[0], body[1], body[2], body[3]
    if length != len(body) - HEADER_LEN - CRC_LEN or length > MAX_PAYLOAD:
        raise FrameError("bad_length", f"header says {length} bytes, frame holds {len(body) - 6}")
    hello = msg_type in (MsgType.HELLO, MsgType.HELLO_REPLY)
    if (version >> 4) != (VERSION_BYTE >> 4) and not (hello or accept_any_version):
        raise FrameError("bad_version", f"protocol version byte 0x{version:02X}")
    if msg_type not in MESSAGES:
        raise FrameError("unknown_type", f"type 0x{msg_type:02X}")
    return Frame(msg_type, seq, bytes(body[HEADER_LEN:-CRC_LEN]), version)


@dataclass
class FrameDecoder:
    """Incremental decoder: feed bytes as they arrive, get complete valid frames back.

    Bad frames are dropped and counted by reason; the decoder resynchronises at the next
    0x00. Bytes beyond ``MAX_FRAME_LEN`` without a delimiter are discarded as overlong.
    """

    counters: dict[str, int] = field(
        default_factory=lambda: {
            "frames": 0,
            "bad_cobs": 0,
            "bad_crc": 0,
            "bad_length": 0,
            "bad_version": 0,
            "unknown_type": 0,
            "overlong": 0,
        }
    )
    _buf: bytearray = field(default_factory=bytearray)
    _overlong: bool = False

    def feed(self, data: bytes) -> list[Frame]:
        """Consume ``data``; return the frames it completed, in order."""
        frames: list[Frame] = []
        for chunk_end, part in _split_keep(data):
            if self._overlong:
                if chunk_end:
                    self._overlong = False
                    self._buf.clear()
                continue
            self._buf += part
            if len(self._buf) > MAX_FRAME_LEN:
                self.counters["overlong"] += 1
                self._buf.clear()
                self._overlong = not chunk_end
                continue
            if chunk_end:
                if self._buf:
                    try:
                        frames.append(decode_frame(self._buf))
                        self.counters["frames"] += 1
                    except FrameError as err:
                        self.counters[err.reason] += 1
                    self._buf.clear()
        return frames

    @property
    def dropped(self) -> int:
        """Frames dropped for any reason."""
        return sum(v for k, v in self.counters.items() if k != "frames")


def _split_keep(data: bytes):
    """Yield (ends_with_delimiter, bytes_before_it) pieces of ``data``."""
    start = 0
    while True:
        i = data.find(0, start)
        if i < 0:
            if start < len(data):
                yield False, data[start:]
            return
        yield True, data[start:i]
        start = i + 1
