"""The flash model store on the real firmware in simavr and on the emulator: a 3-DoF model set at
the paper's orders (three 3-input WH models, 2 poles per block) with 8 breakpoints and full
tables (863..919 B: more than the EEPROM's 776-byte area; the paper's 10 breakpoints take
compact tables in a 1,016-byte slot and then fit the EEPROM) stored twice, in the two flash slots; the newer runs, bit-exact
against the Python reference; an upload torn after any page, or carrying a corrupted byte,
leaves the previous set running; an EEPROM write after a flash upload runs, and a later upload
runs again. Model sets come from porosense.quant.random_models (an independent generator, wide
random coefficients, fixed seeds), not from the code under test."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from porosense.device import Device
from porosense.firmware.flash_store import FLASH_SLOT0, SLOT_PAGES, pages_from_hex, plan_upload
from porosense.protocol import model_layout as L
from porosense.quant import FixedPointEstimator, ModelBlob, quantize
from porosense.quant.random_models import random_structure

ROOT = Path(__file__).resolve().parents[2]
ELF = ROOT / "firmware" / "build" / "porosense.elf"


def paper_set(seed: int) -> bytes:
    """A 3-DoF set at the paper's poles: 3 outputs x 3 inputs, WH, 2 + 2 poles, 8 breakpoints."""
    s = random_structure(np.random.default_rng(seed), 3, 3, h1_poles=2, h2_poles=2, breakpoints=8, kind="wh")
    return quantize(s, input_range=(-90.0, 10.0), capacity=L.FLASH_BLOB_MAX, noise_lsb=0).blob.to_bytes()


def inputs(n: int = 300, seed: int = 5) -> np.ndarray:
    """dR in 0.01 % on three channels: a random walk over the actuators' range."""
    return np.clip(np.cumsum(np.random.default_rng(seed).normal(0, 300, (n, 3)), axis=0), -9000, 4000).astype(np.int16)


def reference(blob: bytes, x: np.ndarray) -> np.ndarray:
    out, _ = FixedPointEstimator(ModelBlob.from_bytes(blob, max_length=L.FLASH_BLOB_MAX)).run(x)
    return np.asarray(out, dtype=np.int16)


@pytest.fixture(scope="module")
def sets():
    old, new, older = paper_set(11), paper_set(12), paper_set(13)
    # Full tables, more than the EEPROM's area: only the flash store holds them.
    assert all(L.AREA_LEN < len(b) <= L.FLASH_BLOB_MAX for b in (old, new, older)), [len(b) for b in (old, new, older)]
    return old, new, older


@pytest.fixture
def simboard():
    try:
        from porosense.simboard import SimBoard
        from porosense.simboard.board import harness_path
    except ImportError as exc:
        pytest.skip(f"porosense.simboard is not available ({exc})")
    if not ELF.is_file() or not Path(harness_path()).is_file():
        pytest.skip("firmware ELF or simboard harness not built")
    with SimBoard(elf=str(ELF), actuator="3dof") as board:
        yield board


def _upload(board, dev, blob: bytes, n_pages: int | None = None):
    plan = plan_upload(blob, dev.model_info())
    board.program_flash(pages_from_hex(plan.to_hex()), n_pages)  # through the HEX, as avrdude gets it
    dev.after_reset()
    return plan


@pytest.mark.simboard
def test_paper_set_twice_in_flash_newer_runs_bit_exact(simboard, sets):
    old, new, _ = sets
    x = inputs()
    with Device.open(simboard.url, timeout_scale=4.0) as dev:
        assert _upload(simboard, dev, old).slot == 0
        info = dev.model_info()
        assert (info.valid, info.slot, info.crc, info.store) == (
            True,
            FLASH_SLOT0,
            ModelBlob.from_bytes(old, max_length=L.FLASH_BLOB_MAX).crc,
            "flash",
        )
        plan = _upload(simboard, dev, new)
        info = dev.model_info()
        assert (plan.slot, info.slot, info.seq, info.length) == (1, FLASH_SLOT0 + 1, 1, len(new))
        got = np.asarray(dev.replay(x))
        assert np.array_equal(got, reference(new, x)), "the newer set differs from the reference"
        # MODEL_READ reads the running set back from flash.
        readback = b"".join(dev.read_model_bytes(o, min(112, len(new) - o)) for o in range(0, len(new), 112))
        assert readback == new


@pytest.mark.simboard
@pytest.mark.parametrize("cut", range(SLOT_PAGES + 1))
def test_upload_torn_after_each_page_keeps_the_previous_set(simboard, sets, cut):
    old, new, older = sets
    x = inputs(120)
    with Device.open(simboard.url, timeout_scale=4.0) as dev:
        _upload(simboard, dev, older)  # slot 0, counter 0
        _upload(simboard, dev, old)  # slot 1, counter 1: running
        plan = _upload(simboard, dev, new, n_pages=cut)  # over slot 0 (the older set), torn
        info = dev.model_info()
        expect = new if cut == SLOT_PAGES else old
        assert plan.slot == 0 and info.valid and info.length == len(expect), (cut, info)
        assert info.slot == FLASH_SLOT0 + (0 if cut == SLOT_PAGES else 1)
        assert np.array_equal(np.asarray(dev.replay(x)), reference(expect, x))


@pytest.mark.simboard
def test_corrupt_upload_and_eeprom_in_between(simboard, sets):
    from models import make_blob

    old, new, _ = sets
    x = inputs(120)
    with Device.open(simboard.url, timeout_scale=4.0) as dev:
        _upload(simboard, dev, old)
        plan = plan_upload(new, dev.model_info())
        pages = plan.pages()
        addr, data = pages[3]
        pages[3] = (addr, data[:50] + bytes([data[50] ^ 0x20]) + data[51:])  # one bit flipped in transit
        simboard.program_flash(pages)
        dev.after_reset()
        info = dev.model_info()
        assert info.slot == FLASH_SLOT0 and info.length == len(old), info
        # EEPROM newer than flash: a protocol write beside the flash model runs (counter + 1) ...
        small = make_blob(1)
        info = dev.write_model(small)
        assert info.store == "eeprom" and info.seq == 1
        simboard.reset()
        dev.after_reset()
        assert dev.model_info().crc == info.crc
        # ... and back: an upload after it runs again.
        _upload(simboard, dev, new)
        info = dev.model_info()
        assert info.store == "flash" and info.seq == 2 and info.length == len(new)
        assert np.array_equal(np.asarray(dev.replay(x)), reference(new, x))


def test_emulator_takes_the_same_uploads(sets):
    from porosense.emulator import Emulator

    old, new, _ = sets
    x = inputs(120)
    with Emulator("3dof") as emu, Device.open(emu.url) as dev:
        for blob, slot in ((old, 0), (new, 1)):
            plan = plan_upload(blob, dev.model_info())
            emu.program_flash(pages_from_hex(plan.to_hex()))
            assert plan.slot == slot and dev.model_info().slot == FLASH_SLOT0 + slot
        emu.program_flash(plan_upload(old, dev.model_info()).pages(), n_pages=SLOT_PAGES - 1)  # torn
        assert dev.model_info().length == len(new)
        assert np.array_equal(np.asarray(dev.replay(x)), reference(new, x))
