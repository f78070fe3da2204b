"""Property tests of the Python codec (hypothesis, derandomized: the same cases every run).

Default runs keep the example counts small; the slow-marked twins run ten times more (600: a
property that fails on 1 % of inputs is found with probability 1 - 0.99^600 = 99.8 %), the
same count in CI and on any machine.
"""

from __future__ import annotations

import pytest
from cobs import cobs
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from protocol_testing import catalogue, flip_burst, vectors

from porosense.protocol import MESSAGES, FrameDecoder, encode_frame, encode_message
from porosense.protocol.framing import CRC_LEN, HEADER_LEN

FAST = settings(
    max_examples=60, derandomize=True, database=None, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
SLOW = settings(FAST, max_examples=600)

INT_RANGES = {
    "u8": (0, 0xFF),
    "i8": (-0x80, 0x7F),
    "u16": (0, 0xFFFF),
    "i16": (-0x8000, 0x7FFF),
    "u32": (0, 0xFFFFFFFF),
    "i32": (-0x80000000, 0x7FFFFFFF),
}
SPECS = {m.type: m for m in catalogue()["messages"]}


def _element(base: str):
    if base == "f32":  # any finite float32 (NaN would not compare equal to itself)
        return st.floats(width=32, allow_nan=False)
    lo, hi = INT_RANGES[base]
    return st.integers(lo, hi)


@st.composite
def messages(draw, types=tuple(MESSAGES)):
    """A message of any catalogue type with arbitrary field values."""
    spec = SPECS[draw(st.sampled_from(types))]
    kwargs = {}
    for f in spec.fields:
        if f.count is None:
            kwargs[f.name] = draw(_element(f.base))
        elif f.count == 0 and f.base == "u8":
            kwargs[f.name] = draw(st.binary(max_size=f.max))
        else:
            n = f.count or draw(st.integers(0, f.max))
            kwargs[f.name] = tuple(draw(st.lists(_element(f.base), min_size=n, max_size=n)))
    return MESSAGES[spec.type](**kwargs)


def _frames_of(data: bytes):
    dec = FrameDecoder()
    return dec.feed(data), dec


def _round_trip(msg, seq):
    frames, dec = _frames_of(encode_message(msg, seq))
    assert len(frames) == 1 and dec.dropped == 0
    assert frames[0].seq == seq and frames[0].message() == msg


@FAST
@given(msg=messages(), seq=st.integers(0, 255))
def test_round_trip_every_message_type(msg, seq):
    _round_trip(msg, seq)


@pytest.mark.parametrize("msg_type", sorted(MESSAGES), ids=[MESSAGES[t].__name__ for t in sorted(MESSAGES)])
@settings(FAST, max_examples=10)
@given(data=st.data())
def test_round_trip_each_type(msg_type, data):
    _round_trip(data.draw(messages(types=(msg_type,))), data.draw(st.integers(0, 255)))


def _sample_frames():
    return [bytes.fromhex(v["frame"]) for v in vectors()["frames"]]


def test_every_single_bit_flip_on_the_wire_is_rejected():
    """Exhaustive over every golden frame: flip each bit before the delimiter."""
    tried = accepted = 0
    for frame in _sample_frames():
        for bit in range((len(frame) - 1) * 8):
            frames, _ = _frames_of(b"\x00" + flip_burst(frame, bit, 1, 0))
            tried += 1
            accepted += len(frames)
    assert tried > 9_000
    assert accepted == 0, f"{accepted} of {tried} single-bit flips accepted"


def _body_of(frame: bytes) -> bytes:
    return cobs.decode(frame[:-1])


def _check_burst(frame: bytes, where: str, position: float, length: int, inner: int):
    if where == "body":  # the frame's content: the CRC guarantees detection of every burst <= 16
        body = _body_of(frame)
        first = int(position * (len(body) * 8 - length))
        wire = cobs.encode(flip_burst(body, first, length, inner)) + b"\x00"
    else:  # the COBS bytes on the wire, delimiter excluded
        first = int(position * ((len(frame) - 1) * 8 - length))
        wire = flip_burst(frame, first, length, inner)
    frames, dec = _frames_of(b"\x00" + wire)
    assert frames == [], f"{where} burst of {length} bits at bit {first} accepted"
    assert dec.dropped >= 1


BURSTS = dict(
    frame=st.sampled_from(_sample_frames()),
    where=st.sampled_from(["body", "wire"]),
    position=st.floats(0, 1),
    length=st.integers(1, 16),
    inner=st.integers(0, (1 << 14) - 1),
)


@FAST
@given(**BURSTS)
def test_burst_errors_up_to_16_bits_are_rejected(frame, where, position, length, inner):
    _check_burst(frame, where, position, length, inner)


@pytest.mark.slow
@SLOW
@given(**BURSTS)
def test_burst_errors_up_to_16_bits_are_rejected_many(frame, where, position, length, inner):
    _check_burst(frame, where, position, length, inner)


@st.composite
def garbage_between(draw):
    first = draw(messages())
    second = draw(messages())
    junk = draw(st.one_of(st.binary(max_size=600), st.binary(max_size=600).map(lambda b: b.replace(b"\x00", b"\x01"))))
    return first, junk, second


def _check_resync(first, junk, second):
    stream = encode_message(first, 1) + junk + encode_message(second, 2)
    frames, _ = _frames_of(stream)
    assert frames[0].seq == 1 and frames[0].message() == first
    assert frames[-1].seq == 2 and frames[-1].message() == second


@FAST
@given(case=garbage_between())
def test_garbage_of_any_length_never_stops_the_next_frame(case):
    _check_resync(*case)


@pytest.mark.slow
@SLOW
@given(case=garbage_between())
def test_garbage_of_any_length_never_stops_the_next_frame_many(case):
    _check_resync(*case)


def test_header_is_covered_by_the_crc():
    """A frame whose header was altered but whose CRC was not recomputed is rejected."""
    good = encode_frame(0x13, 9)  # STOP_STREAM, empty payload
    assert len(_body_of(good)) == HEADER_LEN + CRC_LEN
    for i in range(HEADER_LEN):
        raw = bytearray(_body_of(good))
        raw[i] ^= 0x01
        frames, dec = _frames_of(cobs.encode(bytes(raw)) + b"\x00")
        assert frames == [] and dec.counters["bad_crc"] == 1
