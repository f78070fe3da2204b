"""Conformance: handshake, ping, device clock."""

from __future__ import annotations

import re

from porosense.protocol import MsgType
from porosense.protocol._messages import VERSION_MAJOR, HelloReply


def test_hello_reports_versions_capabilities_and_channels(dev):
    info = dev.hello()
    assert info.proto_major == VERSION_MAJOR
    assert re.fullmatch(r"\d+\.\d+\.\d+", info.firmware)
    assert "ESTIMATOR" in info.capabilities
    assert 1 <= info.n_channels <= 3
    assert info.model_status in ("none", "valid", "invalid")
    assert info.streaming is False


def test_hello_with_another_protocol_version_is_answered_in_ours(dev):
    frame = dev.exchange_raw(MsgType.HELLO, b"", version=0x70)  # a future major 7
    assert frame is not None, "HELLO with another version byte got no answer"
    assert frame.type == MsgType.HELLO_REPLY
    assert frame.version >> 4 == VERSION_MAJOR
    assert HelloReply.unpack(frame.payload).proto_major == VERSION_MAJOR


def test_ping_echoes_nonce_and_device_clock_advances(dev):
    first = dev.ping(0xDEADBEEF)
    second = dev.ping(0x01020304)
    assert first.nonce == 0xDEADBEEF and second.nonce == 0x01020304
    assert second.device_time_us > first.device_time_us


def test_uptime_restarts_after_reset(dev):
    before = dev.hello().uptime_ms
    dev.ping()
    info = dev.reset()
    assert info.uptime_ms <= max(before, 0) + 5000
    assert dev.ping().device_time_us < 5_000_000 * dev.timeout_scale
