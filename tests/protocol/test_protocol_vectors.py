"""The Python codec against the golden vectors of protocol/vectors/ (the C++ codec runs the
same vectors in tests/core/test_frame_codec.cpp)."""

from __future__ import annotations

import pytest
from protocol_testing import vectors

from porosense.protocol import MAX_PAYLOAD, MESSAGES, FrameDecoder, decode_frame, encode_frame, frame_len

FRAMES = vectors()["frames"]
STREAMS = vectors()["streams"]


def _message(vec):
    """The generated message object described by a vector's fields."""
    cls = MESSAGES[vec["type"]]
    kwargs = {}
    for name, value in vec["fields"].items():
        if isinstance(value, str):
            kwargs[name] = bytes.fromhex(value)
        elif isinstance(value, list):
            kwargs[name] = tuple(value)
        else:
            kwargs[name] = value
    return cls(**kwargs)


@pytest.mark.parametrize("vec", FRAMES, ids=[v["name"] for v in FRAMES])
def test_frame_vector_encodes_and_decodes_byte_for_byte(vec):
    payload = bytes.fromhex(vec["payload"])
    frame = bytes.fromhex(vec["frame"])
    assert encode_frame(vec["type"], vec["seq"], payload, vec["version"]) == frame
    assert len(frame) == frame_len(len(payload))
    dec = FrameDecoder()
    got = [f for b in frame for f in dec.feed(bytes([b]))]  # one byte at a time
    assert len(got) == 1
    assert (got[0].version, got[0].type, got[0].seq, got[0].payload) == (
        vec["version"],
        vec["type"],
        vec["seq"],
        payload,
    )
    assert dec.counters["frames"] == 1 and dec.dropped == 0
    msg = _message(vec)
    assert msg.pack() == payload
    assert got[0].message() == msg


@pytest.mark.parametrize("vec", STREAMS, ids=[v["name"] for v in STREAMS])
def test_stream_vector_gives_the_expected_frames_and_counters(vec):
    stream = bytes.fromhex(vec["stream"])
    want = [(f["version"], f["type"], f["seq"], bytes.fromhex(f["payload"])) for f in vec["frames"]]
    for pieces in (1, len(stream)):  # all at once, and byte by byte
        dec = FrameDecoder()
        step = max(1, len(stream) // pieces)
        got = [f for i in range(0, len(stream), step) for f in dec.feed(stream[i : i + step])]
        assert [(f.version, f.type, f.seq, f.payload) for f in got] == want
        assert dec.counters == vec["counters"]


def test_vectors_cover_every_type_and_the_edge_cases():
    types = {v["type"] for v in FRAMES}
    assert types == set(MESSAGES), f"missing: {sorted(set(MESSAGES) - types)}"
    sizes = [len(bytes.fromhex(v["payload"])) for v in FRAMES]
    assert min(sizes) == 0 and max(sizes) == MAX_PAYLOAD == 120
    assert any(len(p) >= 30 and set(p) == {0} for p in (bytes.fromhex(v["payload"]) for v in FRAMES))
    reasons = {k for v in STREAMS for k, n in v["counters"].items() if n and k != "frames"}
    assert reasons == {"bad_cobs", "bad_crc", "bad_length", "bad_version", "unknown_type", "overlong"}


def test_decode_frame_names_the_first_failing_check():
    frame = bytes.fromhex(next(v["frame"] for v in FRAMES if v["name"] == "ping"))[:-1]
    damaged = bytearray(frame)
    damaged[6] ^= 0x10
    with pytest.raises(ValueError, match="bad_crc"):
        decode_frame(bytes(damaged))
    with pytest.raises(ValueError, match="bad_cobs"):
        decode_frame(frame[:-2])
