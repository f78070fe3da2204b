"""Model blob serialisation, checks and the C header export."""

import struct
from dataclasses import replace

import numpy as np
import pytest

from porosense.errors import ModelError
from porosense.protocol.framing import crc16
from porosense.protocol.model_blob import FORMAT_VERSION, HEADER_OFFSETS, MAX_BLOB_LEN
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
    assert len(data) == blob.length <= MAX_BLOB_LEN
    assert data[:2] == b"PW" and data[2] == FORMAT_VERSION == 2
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


def _recrc(data: bytearray) -> bytes:
    data[-2:] = crc16(bytes(data[:-2])).to_bytes(2, "little")
    return bytes(data)


def test_format_version_and_length_errors(blob):
    data = bytearray(blob.to_bytes())
    data[2] = 3
    with pytest.raises(ModelError, match="format version 3"):
        ModelBlob.from_bytes(_recrc(data))
    data[2] = 1  # a blob of the format before the sample period and the input scaling
    with pytest.raises(ModelError, match="format version 1.*re-quantize"):
        ModelBlob.from_bytes(_recrc(data))
    with pytest.raises(ModelError, match="length"):
        ModelBlob.from_bytes(blob.to_bytes() + b"\0")


def test_c_header_holds_the_bytes(blob):
    text = c_header(blob, "demo")
    data = blob.to_bytes()
    assert f"#define DEMO_LEN {len(data)}" in text
    listed = [int(v, 16) for v in __import__("re").findall(r"0x([0-9A-F]{2}),", text)]
    assert listed == list(data)
    assert text.count("h1[") == sum(len(b.sections) for o in blob.outputs for b in o.branches)


def test_sample_period_and_input_scaling_are_stored_and_checked(blob):
    """The header carries Ts (us) and the input scaling; a zero period or a scaling other than
    the device's 0.01 % per LSB is refused even with a good CRC."""
    data = bytearray(blob.to_bytes())
    ts_at, lsb_at = HEADER_OFFSETS["ts_us"], HEADER_OFFSETS["input_lsb"]
    assert int.from_bytes(data[ts_at : ts_at + 4], "little") == blob.ts_us == round(blob.ts * 1e6)
    assert struct.unpack_from("<f", data, lsb_at)[0] == pytest.approx(0.01, rel=1e-7)
    bad = bytearray(data)
    bad[ts_at : ts_at + 4] = (0).to_bytes(4, "little")
    with pytest.raises(ModelError, match="sample period"):
        ModelBlob.from_bytes(_recrc(bad))
    bad = bytearray(data)
    struct.pack_into("<f", bad, lsb_at, 1e-4)
    with pytest.raises(ModelError, match="0.0001 % dR per LSB"):
        ModelBlob.from_bytes(_recrc(bad))


def test_quantize_stores_the_models_sample_period():
    s = random_structure(np.random.default_rng(5), 1, 1, h1_poles=2, kind="linear")
    for ts, us in ((0.01, 10_000), (0.02, 20_000), (1 / 30, 33_333)):
        b = quantize(replace(s, ts=ts)).blob
        assert b.ts_us == us and ModelBlob.from_bytes(b.to_bytes()).ts_us == us
    with pytest.raises(ModelError, match="sample period"):
        quantize(replace(s, ts=float("inf")))
