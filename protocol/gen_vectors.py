"""Golden frames of the wire protocol, computed from the catalogue alone.

This is a third, deliberately plain implementation of the framing rules (standard library
only: its own CRC, COBS and reference decoder), so that the firmware codec and the Python
codec are both checked against something that shares no code with either.

Outputs (written by protocol/generate.py):
    protocol/vectors/frames.json   frames and byte streams with the expected outcome
    protocol/vectors/frames.txt    the same, one vector per line, for the C++ test
"""

from __future__ import annotations

import json
import random
import struct

HEADER_LEN = 4
CRC_LEN = 2
STRUCT_CODE = {"u8": "B", "i8": "b", "u16": "H", "i16": "h", "u32": "I", "i32": "i", "f32": "f"}
COUNTERS = ("frames", "bad_cobs", "bad_crc", "bad_length", "bad_version", "unknown_type", "overlong")


# ------------------------------------------------------------------ reference framing


def crc16_mcrf4xx(data: bytes) -> int:
    """Bitwise CRC-16/MCRF4XX: reflected 0x1021 (0x8408), init 0xFFFF, no final xor."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


def cobs_encode(body: bytes) -> bytes:
    assert len(body) < 254, "frames never need a 0xFF COBS code"
    out = bytearray([0])
    code_pos = 0
    for b in body:
        if b == 0:
            out[code_pos] = len(out) - code_pos
            code_pos = len(out)
            out.append(0)
        else:
            out.append(b)
    out[code_pos] = len(out) - code_pos
    return bytes(out)


def cobs_decode(enc: bytes) -> bytes | None:
    """Decoded bytes, or None when the code chain does not end exactly at the end."""
    out = bytearray()
    pos = 0
    while pos < len(enc):
        code = enc[pos]
        if code == 0 or pos + code > len(enc):
            return None
        out += enc[pos + 1 : pos + code]
        pos += code
        if code != 0xFF and pos < len(enc):
            out.append(0)
    return bytes(out)


def encode(version: int, msg_type: int, seq: int, payload: bytes) -> bytes:
    body = bytes((version, msg_type, seq, len(payload))) + payload
    crc = crc16_mcrf4xx(body)
    return cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\x00"


class ReferenceDecoder:
    """The decoding rules of spec.md, written for clarity, not speed."""

    def __init__(self, cat: dict):
        self.major = cat["protocol"]["major"]
        self.max_payload = cat["protocol"]["max_payload"]
        self.window = HEADER_LEN + self.max_payload + CRC_LEN + 2 + 1
        self.bounds = {m.type: (m.min_len, m.max_len) for m in cat["messages"]}
        self.exempt = {m.type for m in cat["messages"] if m.name in ("HELLO", "HELLO_REPLY")}
        self.counters = dict.fromkeys(COUNTERS, 0)

    def check(self, enc: bytes):
        body = cobs_decode(enc)
        if body is None:
            return "bad_cobs", None
        if len(body) < HEADER_LEN + CRC_LEN:
            return "bad_length", None
        if crc16_mcrf4xx(body[:-2]) != body[-2] | body[-1] << 8:
            return "bad_crc", None
        version, msg_type, seq, length = body[:4]
        if length != len(body) - HEADER_LEN - CRC_LEN or length > self.max_payload:
            return "bad_length", None
        foreign = version >> 4 != self.major
        if foreign and msg_type not in self.exempt:
            return "bad_version", None
        if msg_type not in self.bounds:
            return "unknown_type", None
        lo, hi = self.bounds[msg_type]
        if not foreign and not lo <= length <= hi:
            return "bad_length", None
        return "ok", {"version": version, "type": msg_type, "seq": seq, "payload": body[4:-2].hex()}

    def run(self, stream: bytes) -> list[dict]:
        frames = []
        chunk = bytearray()
        overlong = False
        for b in stream:
            if b:
                chunk.append(b)
                if len(chunk) > self.window:
                    if not overlong:
                        self.counters["overlong"] += 1
                    overlong = True
                    del chunk[0]
                continue
            if chunk:
                first = 0
                found = None
                if not overlong:
                    reason, found = self.check(bytes(chunk))
                    if found is None:
                        self.counters[reason] += 1
                        first = 1
                # The longest suffix that is a valid frame, if any (garbage before a frame).
                start = first
                while found is None and start <= len(chunk) - 7:
                    found = self.check(bytes(chunk[start:]))[1]
                    start += 1
                if found is not None:
                    self.counters["frames"] += 1
                    frames.append(found)
            chunk.clear()
            overlong = False
        return frames


# ------------------------------------------------------------------ field values


def _random_value(rng: random.Random, base: str):
    if base == "f32":
        return rng.randint(-40000, 40000) / 16.0  # exactly representable in float32
    bits = int(base[1:])
    if base[0] == "u":
        return rng.choice([0, 1, (1 << bits) - 1, rng.randrange(1 << bits)])
    lim = 1 << (bits - 1)
    return rng.choice([0, -1, lim - 1, -lim, rng.randrange(-lim, lim)])


def _values(msg, rng: random.Random, var_count: int | None = None, fill=None) -> dict:
    """Field values of msg: random (seeded), or every element equal to fill."""
    vals = {}
    for f in msg.fields:

        def one():
            return fill if fill is not None else _random_value(rng, f.base)

        if f.count is None:
            vals[f.name] = one()
        elif f.count == 0:
            n = f.max // 2 if var_count is None else var_count
            items = [one() for _ in range(n)]
            vals[f.name] = bytes(items).hex() if f.base == "u8" else items
        else:
            vals[f.name] = [one() for _ in range(f.count)]
    return vals


def pack(msg, vals: dict) -> bytes:
    out = b""
    for f in msg.fields:
        code = "<" + STRUCT_CODE[f.base]
        v = vals[f.name]
        if f.count == 0 and f.base == "u8":
            out += bytes.fromhex(v)
        elif f.count is None:
            out += struct.pack(code, v)
        else:
            out += b"".join(struct.pack(code, x) for x in v)
    return out


# ------------------------------------------------------------------ the vectors


def build(cat: dict) -> dict:
    """All vectors: frames (encode and decode exactly) and streams (decoder outcomes)."""
    p = cat["protocol"]
    version = p["major"] * 16 + p["minor"]
    by_name = {m.name: m for m in cat["messages"]}
    frames = []

    def add(name, msg, vals, seq, ver=version, why=""):
        payload = pack(msg, vals)
        frames.append(
            {
                "name": name,
                "message": msg.name,
                "type": msg.type,
                "version": ver,
                "seq": seq,
                "fields": vals,
                "payload": payload.hex(),
                "frame": encode(ver, msg.type, seq, payload).hex(),
                "why": why,
            }
        )

    for i, m in enumerate(cat["messages"]):
        rng = random.Random(f"porosense-{m.name}")
        add(m.name.lower(), m, _values(m, rng), (i * 37 + 5) % 256, why="one of each message type")
    chunk, sample, replay = by_name["MODEL_CHUNK"], by_name["SAMPLE"], by_name["REPLAY"]
    v = chunk.variable
    add(
        "max_payload_model_chunk",
        chunk,
        _values(chunk, random.Random(1), var_count=v.max),
        200,
        why=f"largest payload: {chunk.max_len} bytes",
    )
    add(
        "max_payload_zeros",
        chunk,
        _values(chunk, None, var_count=v.max, fill=0),
        0,
        why="largest payload, all 0x00: one COBS code per byte",
    )
    all_ff = _values(chunk, None, var_count=v.max, fill=0xFF)
    all_ff["offset"] = 0xFFFF
    add("max_payload_ff", chunk, all_ff, 255, why="largest payload, no 0x00 at all: one long COBS block")
    add("sample_zeros", sample, _values(sample, None, fill=0), 0, why="fixed payload full of 0x00")
    add(
        "model_chunk_empty",
        chunk,
        _values(chunk, None, var_count=0, fill=0),
        1,
        why="variable message with no trailing elements",
    )
    add(
        "replay_full",
        replay,
        _values(replay, random.Random(2), var_count=replay.variable.max),
        17,
        why="largest REPLAY: 16 samples of 3 inputs",
    )
    hello, hello_reply, ping = by_name["HELLO"], by_name["HELLO_REPLY"], by_name["PING"]
    other = (p["major"] % 15) + 1  # another major than ours
    add("hello_other_major", hello, {}, 3, ver=other * 16 + 1, why="HELLO is accepted with any version")
    add(
        "hello_reply_other_major",
        hello_reply,
        _values(hello_reply, random.Random(3)),
        3,
        ver=other * 16,
        why="HELLO_REPLY too, so the host can report the mismatch",
    )
    add(
        "ping_newer_minor",
        ping,
        {"nonce": 0x01020304},
        9,
        ver=version | 0x0F,
        why="a different minor of the same major is accepted",
    )

    streams = []
    ref_frame = lambda name: bytes.fromhex(next(f["frame"] for f in frames if f["name"] == name))  # noqa: E731

    def add_stream(name, data: bytes, why, expect_reason=None, expect_frames=None):
        dec = ReferenceDecoder(cat)
        got = dec.run(data)
        if expect_reason is not None:
            assert dec.counters[expect_reason] >= 1, (name, dec.counters)
        if expect_frames is not None:
            assert len(got) == expect_frames, (name, got, dec.counters)
        streams.append({"name": name, "stream": data.hex(), "frames": got, "counters": dec.counters, "why": why})

    def body_frame(body: bytes, fix_crc=True) -> bytes:
        if fix_crc:
            crc = crc16_mcrf4xx(body)
            body = body + bytes((crc & 0xFF, crc >> 8))
        return cobs_encode(body) + b"\x00"

    good = ref_frame("ping")
    bad = bytearray(good)
    bad[3] ^= 0x04  # the sequence number: nonzero before and after the flip
    assert bad[3] != 0 and good[3] != 0
    add_stream("bad_crc", bytes(bad), "one flipped bit in the sequence number", "bad_crc", 0)
    add_stream("bad_cobs_truncated", good[:-3] + b"\x00", "frame cut short: the COBS chain overruns", "bad_cobs", 0)
    add_stream("bad_cobs_chain", b"\x05\x11\x22\x00", "code byte claims more bytes than the chunk holds", "bad_cobs", 0)
    add_stream(
        "short_body", b"\x03\x10\x02\x00", "COBS-valid but only 2 bytes: no room for header and CRC", "bad_length", 0
    )
    add_stream(
        "bad_length_header",
        body_frame(bytes((version, ping.type, 1, 5)) + b"\x01\x02\x03\x04"),
        "header says 5 payload bytes, the frame holds 4 (CRC correct)",
        "bad_length",
        0,
    )
    add_stream(
        "bad_length_type",
        body_frame(bytes((version, ping.type, 1, 3)) + b"\x01\x02\x03"),
        "PING needs 4 payload bytes, 3 sent (CRC correct)",
        "bad_length",
        0,
    )
    add_stream(
        "bad_version",
        body_frame(bytes((other * 16, ping.type, 1, 4)) + b"\x01\x02\x03\x04"),
        f"protocol major {other} on a PING",
        "bad_version",
        0,
    )
    add_stream(
        "unknown_type", body_frame(bytes((version, 0x7E, 1, 0))), "type 0x7E is not in the catalogue", "unknown_type", 0
    )
    add_stream("overlong", bytes([0x55]) * 300 + b"\x00", "300 bytes without a delimiter", "overlong", 0)
    add_stream(
        "idle_zeros",
        b"\x00\x00" + good + b"\x00\x00\x00",
        "repeated 0x00 between frames is idle, not an error",
        None,
        1,
    )
    add_stream("two_frames", good + ref_frame("sample"), "back to back", None, 2)
    rng = random.Random(4)
    garbage = bytes(rng.randrange(1, 256) for _ in range(17))
    add_stream(
        "garbage_then_frame",
        garbage + ref_frame("sample"),
        "17 bytes of garbage without 0x00 glued to a SAMPLE: the SAMPLE is recovered",
        None,
        1,
    )
    long_garbage = bytes(rng.randrange(1, 256) for _ in range(300))
    add_stream(
        "overlong_garbage_then_frame",
        long_garbage + ref_frame("max_payload_ff"),
        "300 bytes of garbage then the largest frame: overlong, frame recovered",
        "overlong",
        1,
    )
    half = ref_frame("status_reply")
    add_stream(
        "truncated_then_frame",
        good + half[: len(half) // 2] + ref_frame("ack"),
        "half a frame (transmitter reset) then an ACK: PING and ACK recovered",
        None,
        2,
    )
    add_stream(
        "hello_reply_other_major_layout",
        body_frame(bytes((other * 16, hello_reply.type, 7, 3)) + bytes((other, 1, 0))),
        f"a HELLO_REPLY of major {other} with its own layout is delivered: the host reads proto_major",
        None,
        1,
    )
    add_stream(
        "hello_reply_bad_length",
        body_frame(bytes((version, hello_reply.type, 7, 3)) + bytes((p["major"], 0, 0))),
        "the same length under our own major is wrong",
        "bad_length",
        0,
    )
    zero_in = bytearray(ref_frame("sample"))
    zero_in[10] = 0
    add_stream(
        "zero_inside_frame", bytes(zero_in), "a byte turned into 0x00 splits the frame: both parts dropped", None, 0
    )
    return {"format": 1, "version_byte": version, "frames": frames, "streams": streams}


def to_json(vectors: dict) -> str:
    return json.dumps(vectors, indent=1) + "\n"


def to_text(vectors: dict) -> str:
    """One vector per line, whitespace-separated, '-' for an empty hex string."""
    h = lambda s: s or "-"  # noqa: E731
    out = [
        "# GENERATED by protocol/generate.py from protocol/messages.toml. Do not edit.",
        "# F name version type seq payload_hex frame_hex",
        "#   encoding (version, type, seq, payload) gives frame_hex; decoding frame_hex gives them back",
        "# S name stream_hex " + " ".join(COUNTERS) + " n_frames {version type seq payload_hex} * n_frames",
        "#   feeding stream_hex to a fresh decoder gives exactly these counters and frames",
    ]
    for f in vectors["frames"]:
        out.append(f"F {f['name']} {f['version']} {f['type']} {f['seq']} {h(f['payload'])} {f['frame']}")
    for s in vectors["streams"]:
        parts = ["S", s["name"], h(s["stream"])] + [str(s["counters"][c]) for c in COUNTERS]
        parts.append(str(len(s["frames"])))
        for fr in s["frames"]:
            parts += [str(fr["version"]), str(fr["type"]), str(fr["seq"]), h(fr["payload"])]
        out.append(" ".join(parts))
    return "\n".join(out) + "\n"
