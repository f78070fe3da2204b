"""Version rules: another minor is fine, another major is refused with a clear error."""

from __future__ import annotations

import pytest

from porosense.errors import DeviceError
from porosense.protocol import (
    FrameDecoder,
    HelloReply,
    Ping,
    ProtocolVersionError,
    check_compatible,
    encode_frame,
    encode_message,
    hello_versions,
    split_version,
)
from porosense.protocol._messages import VERSION_BYTE, VERSION_MAJOR, VERSION_MINOR


def test_version_byte_is_major_times_16_plus_minor():
    assert VERSION_BYTE == VERSION_MAJOR * 16 + VERSION_MINOR
    assert split_version(0x2A) == (2, 10)


def test_other_minor_is_compatible_other_major_is_refused():
    check_compatible(VERSION_MAJOR, (VERSION_MINOR + 3) % 16)
    with pytest.raises(
        ProtocolVersionError,
        match=rf"device speaks protocol {VERSION_MAJOR + 1}\.0, this host speaks {VERSION_MAJOR}\.{VERSION_MINOR}",
    ):
        check_compatible(VERSION_MAJOR + 1, 0)
    assert issubclass(ProtocolVersionError, DeviceError)


def test_decoder_delivers_hello_reply_of_any_major_and_drops_other_types():
    foreign = (VERSION_MAJOR + 1) << 4
    reply = encode_frame(HelloReply.TYPE, 4, bytes((VERSION_MAJOR + 1, 2, 0xAB)), version=foreign)
    ping = encode_message(Ping(nonce=1), 5, version=foreign)
    dec = FrameDecoder()
    frames = dec.feed(reply + ping)
    assert [f.type for f in frames] == [HelloReply.TYPE]
    assert hello_versions(frames[0].payload) == (VERSION_MAJOR + 1, 2)
    assert dec.counters["bad_version"] == 1
    with pytest.raises(ProtocolVersionError):
        check_compatible(*hello_versions(frames[0].payload))
    with pytest.raises(ProtocolVersionError, match="carries no protocol version"):
        hello_versions(b"\x01")
