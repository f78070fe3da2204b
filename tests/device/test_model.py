"""Conformance: model flash, commit, info, read back, erase, refusals, torn writes.

The model store keeps the running model until a new one is whole and checked (two slots,
firmware/lib/core/model_store.h). The Python emulator still has the one-slot store it was
written with and is being replaced by the firmware core; the tests of the two-slot behaviour
run on the firmware back-ends only."""

from __future__ import annotations

import pytest

from porosense.device import NakError
from porosense.device.client import MODEL_CHUNK_BYTES, blob_crc
from porosense.protocol import Result, StatusFlag
from porosense.protocol import _messages as m
from porosense.protocol.model_layout import AREA_LEN


def begin(dev, blob, crc=None):
    dev.command(m.ModelBegin(length=len(blob), crc=blob_crc(blob) if crc is None else crc, format_version=blob[2]))


def send_chunks(dev, blob, upto=None):
    end = len(blob) if upto is None else upto
    for off in range(0, end, MODEL_CHUNK_BYTES):
        dev.command(m.ModelChunk(offset=off, data=blob[off : min(off + MODEL_CHUNK_BYTES, end)]))


def nak(fn, *args) -> NakError:
    with pytest.raises(NakError) as err:
        fn(*args)
    return err.value


def test_write_info_read_back_and_hello(dev, blob):
    info = dev.write_model(blob)
    assert info.valid and info.length == len(blob) and info.crc == blob_crc(blob)
    assert info.n_inputs == 1 and info.n_outputs == 1 and info.model_id == 0x5EED0001
    assert info.format_version == blob[2]
    assert len(info.out_scale) == 1 and info.out_scale[0] > 0
    assert dev.read_model() == blob
    hello = dev.hello()
    assert hello.model_status == "valid" and hello.model_crc == blob_crc(blob)
    assert not dev.status().has(StatusFlag.ESTIMATOR_OFF)


def test_model_survives_a_reset(dev, blob3):
    dev.write_model(blob3)
    dev.reset()
    info = dev.model_info()
    assert info.valid and info.crc == blob_crc(blob3) and info.n_outputs == 3


def test_erase(dev, blob):
    dev.write_model(blob)
    dev.erase_model()
    assert dev.model_info().status == "none"
    assert dev.hello().model_status == "none"
    assert dev.status().has(StatusFlag.ESTIMATOR_OFF)
    assert nak(dev.command, m.ModelRead(offset=0, length=8)).code == Result.NO_MODEL


def test_begin_keeps_the_running_model(dev, blob, blob3):
    old = dev.write_model(blob)
    begin(dev, blob3)
    send_chunks(dev, blob3, upto=MODEL_CHUNK_BYTES)
    info = dev.model_info()
    assert info.valid and info.crc == old.crc
    assert not dev.status().has(StatusFlag.ESTIMATOR_OFF)


def test_disconnect_during_a_write_keeps_the_running_model(dev, backend, blob, blob3):
    """The host vanishes mid-write (no commit); a new connection finds the old model running."""
    from porosense.device import Device

    old = dev.write_model(blob)
    begin(dev, blob3)
    send_chunks(dev, blob3, upto=MODEL_CHUNK_BYTES)
    dev.close()
    with Device.open(backend.url, timeout_scale=backend.timeout_scale) as again:
        info = again.model_info()
        assert info.valid and info.crc == old.crc
        assert not again.status().has(StatusFlag.ESTIMATOR_OFF)


def test_chunk_and_commit_without_begin(dev, blob):
    dev.erase_model()
    dev.reset()  # forget any write in progress
    assert nak(dev.command, m.ModelChunk(offset=0, data=blob[:16])).code == Result.BAD_STATE
    assert nak(dev.command, m.ModelCommit()).code == Result.BAD_STATE


def test_non_contiguous_chunk_names_the_expected_offset(dev, blob):
    begin(dev, blob)
    dev.command(m.ModelChunk(offset=0, data=blob[:32]))
    err = nak(dev.command, m.ModelChunk(offset=48, data=blob[48:64]))
    assert err.code == Result.BAD_STATE and err.detail == 32


def test_too_large(dev, blob):
    err = nak(dev.command, m.ModelBegin(length=4000, crc=0, format_version=blob[2]))
    assert err.code == Result.TOO_LARGE and 0 < err.detail < 4000


def test_incomplete_commit_is_refused_and_the_old_model_runs(dev, blob, blob3):
    old = dev.write_model(blob3)
    begin(dev, blob)
    send_chunks(dev, blob, upto=64)
    assert nak(dev.command, m.ModelCommit()).code == Result.BAD_STATE
    info = dev.model_info()
    assert info.valid and info.crc == old.crc


def test_wrong_crc_is_refused_and_the_old_model_runs(dev, blob, blob3):
    old = dev.write_model(blob)
    begin(dev, blob3, crc=blob_crc(blob3) ^ 0x5555)
    send_chunks(dev, blob3)
    assert nak(dev.command, m.ModelCommit()).code == Result.BAD_MODEL
    info = dev.model_info()
    assert info.valid and info.crc == old.crc and not dev.status().has(StatusFlag.ESTIMATOR_OFF)


def _broken(blob: bytes) -> bytes:
    """A blob whose CRC matches but whose content the estimator refuses (seven inputs)."""
    from porosense.protocol import crc16

    broken = bytearray(blob)
    broken[3] = 7  # seven inputs: beyond the firmware's three
    broken[-2:] = crc16(bytes(broken[:-2])).to_bytes(2, "little")
    return bytes(broken)


def test_broken_structure_is_refused_and_the_old_model_runs(dev, blob, blob3):
    old = dev.write_model(blob)
    broken = _broken(blob3)
    begin(dev, broken)
    send_chunks(dev, broken)
    err = nak(dev.command, m.ModelCommit())
    assert err.code == Result.BAD_MODEL and err.detail == 1
    info = dev.model_info()
    assert info.valid and info.crc == old.crc and not dev.status().has(StatusFlag.ESTIMATOR_OFF)


def test_write_model_checks_the_blob_before_sending(dev, blob):
    """Device.write_model refuses a blob the firmware would refuse without sending a byte."""
    from porosense.errors import ModelError

    before = dev.stats.commands
    with pytest.raises(ModelError, match="inputs"):
        dev.write_model(_broken(blob))
    with pytest.raises(ModelError, match="CRC"):
        dev.write_model(blob[:-1] + bytes([blob[-1] ^ 1]))
    assert dev.stats.commands == before


def _could_hurt(blob: bytes, damage: str) -> bytes:
    """``blob`` with one part made dangerous, CRC correct: a section with a pole outside the unit
    circle (|z| = 2.25) or on it (+-1j), or the output table's breakpoints out of order."""
    import dataclasses

    from porosense.protocol.model_blob import ModelBlob

    b = ModelBlob.from_bytes(blob)
    out = b.outputs[0]
    sec = out.branches[0].sections[0]
    if damage == "table":
        out = dataclasses.replace(out, g=dataclasses.replace(out.g, x=(out.g.x[1], out.g.x[0], *out.g.x[2:])))
    else:
        # c1 = m1 + k1 2^-n1, c2 = m2 + k2 2^-n2 (y = ... + c1 y1 + c2 y2)
        m, k = {"outside": ((2, 0), (16384, 0)), "on": ((0, -1), (0, 0))}[damage]
        bad = dataclasses.replace(sec, m=m, k=k, n=(16, 16), delta=False)
        branch = dataclasses.replace(out.branches[0], sections=(bad, *out.branches[0].sections[1:]))
        out = dataclasses.replace(out, branches=(branch, *out.branches[1:]))
    return dataclasses.replace(b, outputs=(out, *b.outputs[1:])).to_bytes()


@pytest.mark.parametrize("damage", ["outside", "on", "table"])
def test_a_model_that_could_hurt_the_board_is_refused_by_the_board(dev, blob, blob3, damage):
    """Sent past the host's checks (which refuse it too), the firmware refuses a blob with a pole
    on or outside the unit circle or a table whose breakpoints do not increase; the old model
    runs."""
    from porosense.errors import ModelError
    from porosense.protocol.model_blob import ModelBlob

    old = dev.write_model(blob)
    bad = _could_hurt(blob3, damage)
    with pytest.raises(ModelError, match="unit circle" if damage != "table" else "not increasing"):
        ModelBlob.from_bytes(bad)
    begin(dev, bad)
    send_chunks(dev, bad)
    err = nak(dev.command, m.ModelCommit())
    assert err.code == Result.BAD_MODEL and err.detail == 1
    info = dev.model_info()
    assert info.valid and info.crc == old.crc and not dev.status().has(StatusFlag.ESTIMATOR_OFF)


@pytest.mark.parametrize("damage", ["outside", "on", "table"])
def test_flash_and_control_refuse_it_before_opening_the_port(blob3, damage, tmp_path, capsys):
    """flash (either store) and control run refuse such a blob with exit 4 and one line, before
    they open the port (/dev/null here) or write a HEX; there is no --force: the board refuses it."""
    import json

    from porosense.cli import main
    from porosense.control.gainsfile import FORMAT, VERSION

    bad = tmp_path / "bad.bin"
    bad.write_bytes(_could_hurt(blob3, damage))
    gains = tmp_path / "gains.json"
    doc = {"format": FORMAT, "version": VERSION, "gains": {"kp_kpa": 2.0, "ki_kpa_per_s": 1.0, "slew_per_s": 50.0}}
    gains.write_text(json.dumps(doc))
    hex_out = tmp_path / "slot.hex"
    for argv in (
        ["flash", "--port", "/dev/null", "--model", str(bad)],
        ["flash", "--port", "/dev/null", "--model", str(bad), "--store", "flash", "--hex-out", str(hex_out)],
        ["control", "run", "--port", "/dev/null", "--model", str(bad), "--gains", str(gains), "--target", "0.5"],
    ):
        code = main(argv)
        err = capsys.readouterr().err.strip()
        words = "unit circle" if damage != "table" else "breakpoints not increasing"
        assert code == 4 and len(err.splitlines()) == 1 and words in err, (argv[:2], err)
    assert not hex_out.exists()


def test_writes_are_refused_while_streaming(dev, blob):
    dev.start_stream(50)
    for msg in (
        m.ModelBegin(length=len(blob), crc=blob_crc(blob), format_version=blob[2]),
        m.ModelChunk(offset=0, data=blob[:8]),
        m.ModelCommit(),
        m.ModelErase(),
    ):
        assert nak(dev.command, msg).code == Result.BUSY
    dev.model_info()  # reading is allowed
    dev.stop_stream()


def test_a_model_that_does_not_fit_beside_the_running_one_is_refused(dev, blob, blob3):
    """Two models share the model area: BEGIN names the excess, the running model stays."""
    old = dev.write_model(blob3)
    big = len(blob3) + 400
    err = nak(dev.command, m.ModelBegin(length=big, crc=0, format_version=blob[2]))
    assert err.code == Result.TOO_LARGE and err.detail == big - (AREA_LEN - len(blob3))
    info = dev.model_info()
    assert info.valid and info.crc == old.crc


def test_reset_during_a_write_leaves_the_old_model(dev, blob, blob3):
    old = dev.write_model(blob)
    begin(dev, blob3)
    send_chunks(dev, blob3, upto=2 * MODEL_CHUNK_BYTES)
    dev.reset()
    info = dev.model_info()
    assert info.valid and info.crc == old.crc
    assert nak(dev.command, m.ModelChunk(offset=2 * MODEL_CHUNK_BYTES, data=blob3[224:240])).code == Result.BAD_STATE
    assert dev.write_model(blob3).valid  # and a new write works


def test_write_model_replaces_only_when_asked_or_with_a_warning(dev, blob3):
    """A second large model does not fit beside the first: replace=False refuses and keeps the
    running model; the default erases first and warns; the CLI needs --replace."""
    from models import make_blob

    from porosense.errors import ModelError

    other = make_blob(3, model_id=0x5EED0033, poles=0.85)
    assert len(other) + len(blob3) > AREA_LEN
    old = dev.write_model(blob3)
    with pytest.raises(ModelError, match="does not fit beside the running one"):
        dev.write_model(other, replace=False)
    info = dev.model_info()
    assert info.valid and info.crc == old.crc
    with pytest.warns(UserWarning, match="erasing it first"):
        new = dev.write_model(other)
    assert new.valid and new.crc == blob_crc(other)
