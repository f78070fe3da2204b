"""`porosense flash --store flash` and `verify` on the flash store, against the emulator: the
HEX the CLI writes holds exactly the 8 pages of the slot that is not running with the next
counter; uploaded (as avrdude would write it) the board runs the model and `verify` replays it
bit for bit from the flash store. Bad uses end in one line with their exit code; the bench's
rate check fails loudly when the advertised rate is not the measured one."""

from __future__ import annotations

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
        code = main(["verify", "--port", emu.url, str(path), "--data", str(csv), "--json"])
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
            (["flash", "--port", emu.url, str(path)], 4, f"exceeds the {L.MAX_BLOB_LEN}-byte"),  # EEPROM: too large
            (["flash", "--port", emu.url, str(path), "--store", "flash", "--set-rate"], 2, "no bootloader"),
            (["flash", "--port", emu.url, str(path), "--hex-out", str(tmp_path / "x.hex")], 2, "--store flash"),
            (
                [
                    "flash",
                    "--port",
                    emu.url,
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
