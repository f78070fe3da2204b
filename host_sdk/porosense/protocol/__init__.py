"""The porosense wire protocol: generated messages and the frame codec.

>>> from porosense.protocol import encode_message, FrameDecoder, Ping
>>> frames = FrameDecoder().feed(encode_message(Ping(nonce=7), seq=1))
>>> frames[0].message()
Ping(nonce=7)
"""

from porosense.protocol._messages import *  # noqa: F401,F403 - the generated catalogue
from porosense.protocol._messages import MESSAGES, MsgType, Result, StatusFlag
from porosense.protocol.framing import (
    COUNTER_NAMES,
    MAX_FRAME_LEN,
    Frame,
    FrameDecoder,
    FrameError,
    crc16,
    decode_frame,
    encode_frame,
    encode_message,
    frame_len,
)
from porosense.protocol.version import ProtocolVersionError, check_compatible, hello_versions, split_version

__all__ = [
    "MESSAGES",
    "MsgType",
    "Result",
    "StatusFlag",
    "COUNTER_NAMES",
    "MAX_FRAME_LEN",
    "Frame",
    "FrameDecoder",
    "FrameError",
    "ProtocolVersionError",
    "check_compatible",
    "crc16",
    "decode_frame",
    "encode_frame",
    "encode_message",
    "frame_len",
    "hello_versions",
    "split_version",
]
