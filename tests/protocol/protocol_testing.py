"""Helpers shared by the protocol tests: the catalogue, vectors and burst errors."""

from __future__ import annotations

import importlib.util
import json
import sys
from functools import cache
from pathlib import Path

from cobs import cobs

from porosense.protocol import MESSAGES, framing

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "protocol" / "vectors" / "frames.json"


@cache
def generator():
    """protocol/generate.py as a module (its catalogue loader and field specs)."""
    spec = importlib.util.spec_from_file_location("porosense_protocol_generate", ROOT / "protocol" / "generate.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it loads
    spec.loader.exec_module(module)
    return module


@cache
def vector_builder():
    """protocol/gen_vectors.py (field values, packing, framing), as generate.py loads it."""
    generator()
    return sys.modules["gen_vectors"]


@cache
def catalogue() -> dict:
    return generator().load()


@cache
def vectors() -> dict:
    return json.loads(VECTORS.read_text())


def flip_burst(data: bytes, first_bit: int, length: int, inner: int) -> bytes:
    """data with a burst of `length` bits flipped from bit `first_bit` (bit i = byte i//8,
    bit i%8, the order a UART sends them): first and last bit flipped, the bits between
    taken from `inner`."""
    out = bytearray(data)
    for k in range(length):
        if k in (0, length - 1) or (inner >> (k - 1)) & 1:
            out[(first_bit + k) // 8] ^= 1 << ((first_bit + k) % 8)
    return bytes(out)


def plausible_except_crc(encoded: bytes) -> bool:
    """True when `encoded` passes every check of the decoder but the CRC: the candidates
    whose acceptance only the CRC (1 in 65536 by chance) prevents."""
    try:
        body = cobs.decode(encoded)
    except cobs.DecodeError:
        return False
    if len(body) < framing.HEADER_LEN + framing.CRC_LEN:
        return False
    version, msg_type, _, length = body[:4]
    if length != len(body) - 6 or length > framing.MAX_PAYLOAD:
        return False
    if version >> 4 != framing.VERSION_MAJOR and msg_type not in framing.VERSION_EXEMPT:
        return False
    cls = MESSAGES.get(msg_type)
    return cls is not None and cls.MIN_LEN <= length <= cls.MAX_LEN


def candidates_in_chunk(chunk: bytes, overlong: bool = False) -> int:
    """How many of the suffixes the decoder tries in a bad chunk are plausible but for the CRC."""
    first = 0 if overlong else 1
    return sum(plausible_except_crc(chunk[s:]) for s in range(first, len(chunk) - framing.MIN_ENCODED_LEN + 1))
