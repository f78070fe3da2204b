"""The porosense wire protocol: generated messages and the frame codec.

>>> from porosense.protocol import encode_message, FrameDecoder, Ping
>>> frames = FrameDecoder().feed(encode_message(Ping(nonce=7), seq=1))
>>> frames[0].message()
Ping(nonce=7)
"""

from porosense.protocol._messages import *  # noqa: F401,F403 - the generated catalogue
from porosense.protocol._messages import MESSAGES, MsgType, Result, StatusFlag
from porosense.protocol.framing import (
    MAX_FRAME_LEN,
    Frame,
    FrameDecoder,
    FrameError,
    crc16,
    decode_frame,
    encode_frame,
    encode_message,
)

__all__ = [
    "MESSAGES",
    "MsgType",
    "Result",
    "StatusFlag",
    "MAX_FRAME_LEN",
    "Frame",
    "FrameDecoder",
    "FrameError",
    "crc16",
    "decode_frame",
    "encode_frame",
    "encode_message",
]
