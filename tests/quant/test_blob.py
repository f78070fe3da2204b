"""Model blob serialisation, checks and the C header export."""

import numpy as np
import pytest

from porosense.errors import ModelError
from porosense.protocol.framing import crc16
from porosense.quant import ModelBlob, c_header, quantize
from porosense.quant.random_models import random_structure


@pytest.fixture(scope="module")
def blob():
    s = random_structure(np.random.default_rng(3), 2, 2, h1_poles=4, h2_poles=2, kind="wh")
    return quantize(s).blob


def test_round_trip(blob):
    data = blob.to_bytes()
    again = ModelBlob.from_bytes(data)
    assert again == blob and again.to_bytes() == data
    assert len(data) == blob.length <= 952
    assert data[:2] == b"PW" and data[2] == 1
    assert blob.crc == crc16(data[:-2]) == int.from_bytes(data[-2:], "little")


def test_every_corrupted_byte_is_refused(blob):
    data = bytearray(blob.to_bytes())
    refused = 0
    for i in range(len(data)):
        data[i] ^= 0x21
        with pytest.raises(ModelError):
            ModelBlob.from_bytes(bytes(data))
        refused += 1
        data[i] ^= 0x21
    assert refused == len(data)


def test_format_version_and_length_errors(blob):
    data = bytearray(blob.to_bytes())
    data[2] = 2
    data[-2:] = crc16(bytes(data[:-2])).to_bytes(2, "little")
    with pytest.raises(ModelError, match="format version 2"):
        ModelBlob.from_bytes(bytes(data))
    with pytest.raises(ModelError, match="length"):
        ModelBlob.from_bytes(blob.to_bytes() + b"\0")


def test_c_header_holds_the_bytes(blob):
    text = c_header(blob, "demo")
    data = blob.to_bytes()
    assert f"#define DEMO_LEN {len(data)}" in text
    listed = [int(v, 16) for v in __import__("re").findall(r"0x([0-9A-F]{2}),", text)]
    assert listed == list(data)
    assert text.count("h1[") == sum(len(b.sections) for o in blob.outputs for b in o.branches)
