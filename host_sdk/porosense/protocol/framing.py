"""Frames of the wire protocol: COBS(header | payload | crc) followed by one 0x00.

header = version (u8, major * 16 + minor), type (u8), sequence (u8), payload length (u8);
crc is CRC-16/MCRF4XX over header and payload, low byte first. See protocol/spec.md.

The decoder here and the firmware's (firmware/lib/core/frame_codec.cpp) make the same
decisions byte for byte: same checks in the same order, same counters, same recovery of a
frame that follows garbage without a 0x00 (protocol/vectors/ holds the shared cases).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import crcmod.predefined
from cobs import cobs

from porosense.protocol._messages import MAX_PAYLOAD, MESSAGES, VERSION_BYTE, VERSION_MAJOR, MsgType

HEADER_LEN = 4
CRC_LEN = 2
DELIMITER = b"\x00"
# COBS adds one byte per 254 and one overhead byte; plus the delimiter.
MAX_FRAME_LEN = HEADER_LEN + MAX_PAYLOAD + CRC_LEN + 2 + 1
# Smallest encoded frame without its delimiter: COBS code byte + header + crc.
MIN_ENCODED_LEN = 1 + HEADER_LEN + CRC_LEN
# Types accepted with any protocol version, so that a version mismatch can be reported.
VERSION_EXEMPT = frozenset((MsgType.HELLO, MsgType.HELLO_REPLY))
COUNTER_NAMES = ("frames", "bad_cobs", "bad_crc", "bad_length", "bad_version", "unknown_type", "overlong")

_crc16 = crcmod.predefined.mkCrcFun("crc-16-mcrf4xx")


def crc16(data: bytes) -> int:
    """CRC-16/MCRF4XX of ``data`` (poly 0x1021 reflected, init 0xFFFF); b"123456789" -> 0x6F91.

    Parameters
    ----------
    data : bytes-like
        The bytes to check (a frame's header and payload).

    Returns
    -------
    int
        The CRC, 0..0xFFFF (sent low byte first).
    """
    return _crc16(bytes(data))


def frame_len(payload_len: int) -> int:
    """Bytes on the wire of a frame with ``payload_len`` payload bytes, delimiter included.

    Exact for every payload: a body (at most 126 bytes) never fills a 254-byte COBS block,
    so COBS always adds exactly one byte, whatever the content.

    Parameters
    ----------
    payload_len : int
        Payload length, bytes (0..120).

    Returns
    -------
    int
        Frame length on the wire, bytes (payload + 8).

    Raises
    ------
    ValueError
        A payload length outside 0..120.
    """
    if not 0 <= payload_len <= MAX_PAYLOAD:
        raise ValueError(f"payload of {payload_len} bytes outside 0..{MAX_PAYLOAD}")
    return payload_len + HEADER_LEN + CRC_LEN + 1 + 1


@dataclass(frozen=True)
class Frame:
    """One decoded frame: the raw header fields and payload bytes.

    Attributes
    ----------
    type : int
        Message type id (``MsgType``), 0..255.
    seq : int
        Sequence number, 0..255 (a reply carries its command's).
    payload : bytes
        The payload, 0..120 bytes, little-endian fields as laid out in protocol/spec.md.
    version : int
        Header version byte, major * 16 + minor (this host's by default).
    """

    type: int
    seq: int
    payload: bytes
    version: int = VERSION_BYTE

    def message(self):
        """The payload as its generated message class.

        Returns
        -------
        Message
            E.g. ``Pong(nonce=7, device_time_us=...)``.

        Raises
        ------
        ValueError
            An unknown type or a payload of the wrong length.
        """
        cls = MESSAGES.get(self.type)
        if cls is None:
            raise ValueError(f"unknown message type 0x{self.type:02X}")
        return cls.unpack(self.payload)

    def encode(self) -> bytes:
        """This frame on the wire.

        Returns
        -------
        bytes
            COBS-encoded, delimiter included.
        """
        return encode_frame(self.type, self.seq, self.payload, self.version)

    @property
    def name(self) -> str:
        try:
            return MsgType(self.type).name
        except ValueError:
            return f"0x{self.type:02X}"


def encode_frame(msg_type: int, seq: int, payload: bytes = b"", version: int = VERSION_BYTE) -> bytes:
    """Encode one frame, delimiter included.

    Parameters
    ----------
    msg_type : int
        Message type id (``MsgType``); only its low byte is sent.
    seq : int
        Sequence number; only its low byte is sent.
    payload : bytes
        Payload, at most 120 bytes.
    version : int
        Header version byte, major * 16 + minor (this host's by default).

    Returns
    -------
    bytes
        COBS-encoded header, payload and CRC, then one 0x00.

    Raises
    ------
    ValueError
        A payload over 120 bytes.
    """
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = bytes((version & 0xFF, msg_type & 0xFF, seq & 0xFF, len(payload))) + bytes(payload)
    crc = _crc16(body)
    return cobs.encode(body + bytes((crc & 0xFF, crc >> 8))) + DELIMITER


def encode_message(message, seq: int, version: int = VERSION_BYTE) -> bytes:
    """Encode a generated message object as a frame.

    Parameters
    ----------
    message : Message
        An instance of a generated message class (``porosense.protocol.Ping(nonce=7)``, ...).
    seq : int
        Sequence number; only its low byte is sent.
    version : int
        Header version byte, major * 16 + minor (this host's by default).

    Returns
    -------
    bytes
        The frame on the wire, delimiter included.
    """
    return encode_frame(message.TYPE, seq, message.pack(), version)


class FrameError(ValueError):
    """Why a frame was dropped.

    Parameters
    ----------
    reason : str
        The counter of FrameDecoder the drop counts in (``"bad_crc"``, ``"bad_length"``, ...); kept
        as the ``reason`` attribute.
    detail : str
        What exactly was wrong, for the message.
    """

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


def decode_frame(encoded: bytes, accept_any_version: bool = False) -> Frame:
    """Decode one frame (COBS body without the delimiter); raise FrameError if it is bad.

    Checks, in this order (the first failing one names the reason): COBS structure, body
    at least header + crc, CRC, header length equal to the payload held and <= 120, protocol
    major (HELLO and HELLO_REPLY exempt), known type, payload length within the type's bounds
    (not checked for an exempt type of another major).

    Parameters
    ----------
    encoded : bytes
        One COBS-encoded frame without its 0x00 delimiter.
    accept_any_version : bool
        Accept any protocol major for every type, not only HELLO and HELLO_REPLY.

    Returns
    -------
    Frame
        The frame's header fields and payload.

    Raises
    ------
    FrameError
        The first check that fails; its ``reason`` names the counter.
    """
    try:
        body = cobs.decode(bytes(encoded))
    except cobs.DecodeError as exc:
        raise FrameError("bad_cobs", str(exc)) from None
    if len(body) < HEADER_LEN + CRC_LEN:
        raise FrameError("bad_length", f"{len(body)} bytes is shorter than header and CRC")
    crc = body[-2] | (body[-1] << 8)
    if _crc16(body[:-2]) != crc:
        raise FrameError("bad_crc", f"crc 0x{crc:04X} does not match")
    version, msg_type, seq, length = body[0], body[1], body[2], body[3]
    held = len(body) - HEADER_LEN - CRC_LEN
    if length != held or length > MAX_PAYLOAD:
        raise FrameError("bad_length", f"header says {length} bytes, frame holds {held}")
    foreign = (version >> 4) != VERSION_MAJOR
    if foreign and msg_type not in VERSION_EXEMPT and not accept_any_version:
        raise FrameError("bad_version", f"protocol version byte 0x{version:02X}")
    cls = MESSAGES.get(msg_type)
    if cls is None:
        raise FrameError("unknown_type", f"type 0x{msg_type:02X}")
    # Another major may lay HELLO/HELLO_REPLY out differently: only their first bytes count.
    if not foreign and not cls.MIN_LEN <= length <= cls.MAX_LEN:
        raise FrameError(
            "bad_length", f"{cls.__name__} payload of {length} bytes (expected {cls.MIN_LEN}..{cls.MAX_LEN})"
        )
    return Frame(msg_type, seq, bytes(body[HEADER_LEN:-CRC_LEN]), version)


def _valid_suffix(chunk: bytes, start: int) -> Frame | None:
    try:
        return decode_frame(chunk[start:])
    except FrameError:
        return None


@dataclass
class FrameDecoder:
    """Incremental decoder: feed bytes as they arrive, get complete valid frames back.

    A chunk (the bytes before a 0x00) that is not a valid frame is dropped and counted once
    by its first failing check. The decoder then looks for a valid frame that ends the chunk:
    the longest suffix that decodes wins, which recovers a frame preceded by garbage that
    held no 0x00. A chunk longer than ``MAX_FRAME_LEN`` counts as overlong; only its last
    ``MAX_FRAME_LEN`` bytes are kept for that search. Empty chunks (repeated 0x00) are idle.

    Attributes
    ----------
    counters : dict of str to int
        Valid frames (``"frames"``) and dropped chunks by reason (the names in ``COUNTER_NAMES``).
    """

    counters: dict[str, int] = field(default_factory=lambda: dict.fromkeys(COUNTER_NAMES, 0))
    _buf: bytearray = field(default_factory=bytearray)
    _overlong: bool = False

    def feed(self, data: bytes) -> list[Frame]:
        """Consume bytes as they arrive.

        Parameters
        ----------
        data : bytes
            Any number of bytes, split anywhere.

        Returns
        -------
        list of Frame
            The valid frames these bytes completed, in order (dropped chunks go to ``counters``).
        """
        frames: list[Frame] = []
        for chunk_end, part in _split_keep(bytes(data)):
            if part:
                self._buf += part
                if len(self._buf) > MAX_FRAME_LEN:
                    if not self._overlong:
                        self._overlong = True
                        self.counters["overlong"] += 1
                    del self._buf[:-MAX_FRAME_LEN]
            if chunk_end:
                frame = self._end_of_chunk()
                if frame is not None:
                    frames.append(frame)
        return frames

    def reset(self) -> None:
        """Forget the partial chunk and zero the counters."""
        self._buf.clear()
        self._overlong = False
        self.counters = dict.fromkeys(COUNTER_NAMES, 0)

    def _end_of_chunk(self) -> Frame | None:
        chunk = bytes(self._buf)
        overlong = self._overlong
        self._buf.clear()
        self._overlong = False
        if not chunk:
            return None
        first = 0
        if not overlong:
            try:
                frame = decode_frame(chunk)
            except FrameError as err:
                self.counters[err.reason] += 1
                first = 1
            else:
                self.counters["frames"] += 1
                return frame
        for start in range(first, len(chunk) - MIN_ENCODED_LEN + 1):
            found = _valid_suffix(chunk, start)
            if found is not None:
                self.counters["frames"] += 1
                return found
        return None

    @property
    def dropped(self) -> int:
        """Chunks dropped for any reason."""
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
