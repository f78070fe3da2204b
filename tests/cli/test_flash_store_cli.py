"""`porosense flash --store flash` and `verify` on the flash store, against the emulator: the
HEX the CLI writes holds exactly the 8 pages of the slot that is not running with the next
counter; uploaded (as avrdude would write it) the board runs the model and `verify` replays it
bit for bit from the flash store. Bad uses end in one line with their exit code; the bench's
rate check fails loudly when the advertised rate is not the measured one."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.firmware.flash_store import FLASH_SLOT0, SLOT_PAGES, pages_from_hex
from porosense.protocol import model_layout as L


@pytest.fixture(scope="module")
def paper_blob(tmp_path_factory):
    from porosense.quant import quantize
    from porosense.quant.random_models import random_structure

    d = tmp_path_factory.mktemp("flashcli")
    # Full tables with 8 breakpoints: more than the EEPROM's area, within a 1,016-byte slot.
    s = random_structure(np.random.default_rng(7), 3, 3, h1_poles=2, h2_poles=2, breakpoints=8, kind="wh")
    data = quantize(s, input_range=(-90.0, 10.0), capacity=L.FLASH_BLOB_MAX, noise_lsb=0).blob.to_bytes()
    path = d / "paper3dof.bin"
    path.write_bytes(data)
    # A recording to replay: dR on three channels at the model's 50 Hz.
    rng = np.random.default_rng(8)
    dr = np.clip(np.cumsum(rng.normal(0, 3, (400, 3)), axis=0), -90, 40)
    t = np.arange(400) * 0.02
    csv = d / "replay.csv"
    csv.write_text("t,dR_0,dR_1,dR_2\n" + "\n".join(f"{a:.2f},{b:.2f},{c:.2f},{e:.2f}" for a, (b, c, e) in zip(t, dr)))
    return path, data, csv


def test_hex_out_upload_and_verify_from_flash(paper_blob, tmp_path, capsys):
    from porosense.emulator import Emulator

    path, data, csv = paper_blob
    assert len(data) > L.AREA_LEN  # more than the EEPROM holds
    with Emulator("3dof") as emu:
        for slot in (0, 1):
            hex_file = tmp_path / f"slot{slot}.hex"
            code = main(
                [
                    "flash",
                    "--port",
                    emu.url,
                    "--model",
                    str(path),
                    "--store",
                    "flash",
                    "--hex-out",
                    str(hex_file),
                    "--json",
                    "--set-rate",
                ]
            )
            out = json.loads(capsys.readouterr().out)
            assert code == 0 and (out["flash_slot"], out["seq"]) == (slot, slot)
            pages = pages_from_hex(hex_file.read_text())
            assert len(pages) == SLOT_PAGES and pages[0][0] == L.FLASH_BASE + slot * L.FLASH_SLOT_SIZE
            assert b"".join(p for _, p in pages)[: len(data)] == data
            emu.program_flash(pages)
        code = main(["verify", "--port", emu.url, "--model", str(path), "--data", str(csv), "--json"])
        cap = capsys.readouterr()
        assert code == 0, cap.err
        result = json.loads(cap.out)
        assert code == 0 and result["identical"] and result["samples"] == 400
        assert (result["store"], result["slot"], result["seq"]) == ("flash", FLASH_SLOT0 + 1, 1)


def test_flash_store_refusals_are_one_line(paper_blob, tmp_path, capsys):
    from porosense.emulator import Emulator

    path, _, _ = paper_blob
    with Emulator("3dof") as emu:
        cases = [
            (
                ["flash", "--port", emu.url, "--model", str(path)],
                4,
                f"exceeds the {L.MAX_BLOB_LEN}-byte",
            ),  # EEPROM: too large
            (["flash", "--port", emu.url, "--model", str(path), "--store", "flash", "--set-rate"], 2, "no bootloader"),
            (
                ["flash", "--port", emu.url, "--model", str(path), "--hex-out", str(tmp_path / "x.hex")],
                2,
                "--store flash",
            ),
            (
                [
                    "flash",
                    "--port",
                    emu.url,
                    "--model",
                    str(path),
                    "--store",
                    "flash",
                    "--set-rate",
                    "--hex-out",
                    str(tmp_path / "no" / "x.hex"),
                ],
                2,
                "does not exist",
            ),
        ]
        for args, want, words in cases:
            code = main(args)
            err = capsys.readouterr().err.strip()
            assert code == want and len(err.splitlines()) == 1 and words in err, (args, code, err)


def test_bench_fails_when_advertised_rate_is_not_the_measured_one(monkeypatch, capsys):
    import porosense.bench.firmware as fw

    def measured(rate):
        return lambda size: {
            "summary": ["rates"],
            "advertised_equals_measured": rate == fw.advertised_max_rate_hz(),
            "max_clean_rates": {"advertised_max_hz": fw.advertised_max_rate_hz(), "measured_max_hz": rate},
        }

    monkeypatch.setattr(fw, "run", measured(fw.advertised_max_rate_hz() - 7))
    assert main(["bench", "firmware", "--size", "full"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "set SAMPLE_RATE_HZ max" in err
    monkeypatch.setattr(fw, "run", measured(fw.advertised_max_rate_hz()))
    assert main(["bench", "firmware", "--size", "full"]) == 0


def test_flash_store_needs_a_board_that_reads_it(paper_blob, capsys, monkeypatch):
    """A board that does not set FLASH_STORE (an image reaching into the store, or firmware
    older than protocol 2.2, which does not say) is refused before anything is written."""
    from porosense.device.results import HelloInfo
    from porosense.emulator import Emulator
    from porosense.errors import DeviceError
    from porosense.firmware.flash_store import require_flash_store

    def hello(minor, caps):
        return HelloInfo(2, minor, "1.0.0", caps, 3, "none", 0, False, 0)

    require_flash_store(hello(2, ["ADC", "FLASH_STORE"]))
    with pytest.raises(DeviceError, match="reaches into the flash model store"):
        require_flash_store(hello(2, ["ADC", "ESTIMATOR"]))
    with pytest.raises(DeviceError, match="does not say"):
        require_flash_store(hello(1, ["ADC", "ESTIMATOR"]))
    path, _, _ = paper_blob
    hex_out = path.parent / "old_board.hex"
    # A board of protocol 2.1 (the emulator claims it; such firmware never sets FLASH_STORE).
    plain = HelloInfo.from_message.__func__

    def without_flash_store(cls, msg):
        info = plain(cls, msg)
        return dataclasses.replace(info, capabilities=[c for c in info.capabilities if c != "FLASH_STORE"])

    monkeypatch.setattr(HelloInfo, "from_message", classmethod(without_flash_store))
    with Emulator("3dof", proto_version=(2, 1)) as emu:
        code = main(["flash", "--port", emu.url, "--model", str(path), "--store", "flash", "--hex-out", str(hex_out)])
    err = capsys.readouterr().err.strip()
    assert code == 3 and len(err.splitlines()) == 1 and "does not say" in err, err
    assert not hex_out.exists()


def test_firmware_upload_refuses_an_image_over_the_store(tmp_path, capsys):
    from intelhex import IntelHex

    def hex_file(name, start, n):
        ih = IntelHex()
        ih.frombytes(bytes(range(256)) * (n // 256) + bytes(n % 256), offset=start)
        path = tmp_path / name
        ih.write_hex_file(str(path))
        return path

    over = hex_file("over.hex", 0, L.FLASH_BASE + 1)
    code = main(["firmware", "upload", "--port", "/dev/null", "--hex", str(over)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "inside the flash model store" in err, err
    assert "1 B over its budget" in err
    (tmp_path / "junk.hex").write_bytes(b"\x00\xff not hex")
    code = main(["firmware", "upload", "--port", "/dev/null", "--hex", str(tmp_path / "junk.hex")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "not an Intel HEX file" in err, err
    # An image that ends exactly at the store's base passes the check (and then needs avrdude).
    fits = hex_file("fits.hex", 0, L.FLASH_BASE)
    code = main(["firmware", "upload", "--port", "/dev/null", "--hex", str(fits), "--avrdude", "/bin/false"])
    err = capsys.readouterr().err.strip()
    assert "flash model store" not in err and code == 3, err
