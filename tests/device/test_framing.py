"""Conformance: damaged frames are dropped without an answer and counted in STATUS."""

from __future__ import annotations

from porosense.protocol import MsgType, encode_frame, encode_message
from porosense.protocol import _messages as m
from porosense.protocol._messages import VERSION_BYTE


def counters(dev):
    st = dev.status()
    return st.bad_crc, st.bad_length, st.bad_version, st.unknown_type


def expect_silence_and_count(dev, data: bytes, index: int):
    before = counters(dev)
    dev.send_raw(data)
    after = counters(dev)
    delta = [a - b for a, b in zip(after, before)]
    want = [0, 0, 0, 0]
    want[index] = 1
    assert delta == want, delta
    assert dev.ping().nonce is not None  # still answering


def test_bad_crc(dev):
    frame = bytearray(encode_message(m.Ping(nonce=1), seq=0x10))
    frame[3] ^= 0x01  # inside the payload; never the delimiter
    expect_silence_and_count(dev, bytes(frame), 0)


def test_bad_length(dev):
    # A PING whose header claims 5 payload bytes but holds 4 (built by hand, valid CRC).
    from cobs import cobs

    from porosense.protocol import crc16

    body = bytes((VERSION_BYTE, MsgType.PING, 0x11, 5)) + (7).to_bytes(4, "little")
    crc = crc16(body)
    expect_silence_and_count(dev, cobs.encode(body + crc.to_bytes(2, "little")) + b"\x00", 1)


def test_bad_version(dev):
    expect_silence_and_count(
        dev, encode_frame(MsgType.PING, 0x12, (1).to_bytes(4, "little"), version=(VERSION_BYTE + 0x10) & 0xF0), 2
    )


def test_unknown_type(dev):
    expect_silence_and_count(dev, encode_frame(0x55, 0x13, b""), 3)


def test_garbage_before_a_frame_is_skipped(dev):
    reply = dev.exchange_raw(MsgType.PING, (9).to_bytes(4, "little"))
    assert reply is not None
    before = dev.status().rx_frames
    dev.send_raw(b"\x13\x37\xff\x42" + encode_message(m.Ping(nonce=5), seq=0x33))
    assert dev.status().rx_frames - before >= 2  # the PING after the garbage and this STATUS
