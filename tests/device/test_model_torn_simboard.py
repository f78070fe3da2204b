"""The real firmware in simavr loses power in the middle of a model write (the simboard resets
the AVR right after the k-th EEPROM byte write, a torn write): after the reboot the previous
model runs, or the new one once its last header byte is written; never none, never a broken one.

Every run starts from the same EEPROM image (old model stored), so write k is the same byte in
every run; positions cover the first writes, the blob, each slot-header byte and the end."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from models import make_blob, reference_run

from porosense.device import Device
from porosense.device.client import blob_crc
from porosense.errors import DeviceError
from porosense.protocol.model_layout import MAX_BLOB_LEN

ROOT = Path(__file__).resolve().parents[2]
ELF = ROOT / "firmware" / "build" / "porosense.elf"
# One worker runs the module (the start image is a module fixture a second worker would rebuild).
pytestmark = [pytest.mark.simboard, pytest.mark.slow, pytest.mark.xdist_group("torn-simboard")]


@pytest.fixture(scope="module")
def simboard_cls():
    try:
        from porosense.simboard import SimBoard
    except ImportError as exc:
        pytest.skip(f"porosense.simboard is not available ({exc})")
    if not ELF.is_file():
        pytest.skip("firmware ELF not built (make -C firmware)")
    try:
        from porosense.simboard.board import harness_path
    except ImportError:
        harness_path = None
    if harness_path is not None and not Path(harness_path()).is_file():
        pytest.skip("simboard harness not built (make -C tools/simboard)")
    return SimBoard


@pytest.fixture(scope="module")
def start_image(simboard_cls, tmp_path_factory):
    """An EEPROM image holding the old model, and the EEPROM writes a clean new write takes."""
    d = tmp_path_factory.mktemp("torn")
    old, new = make_blob(1), make_blob(3, model_id=0x5EED0003, poles=0.8)
    image = d / "start.bin"
    with simboard_cls(elf=str(ELF), eeprom=image) as board:
        with Device.open(board.url, timeout_scale=5.0) as dev:
            dev.write_model(old)
        board.save_eeprom()
    shutil.copy(image, d / "probe.bin")
    with simboard_cls(elf=str(ELF), eeprom=d / "probe.bin") as board:
        with Device.open(board.url, timeout_scale=5.0) as dev:
            before = board.counters["eeprom_writes"]
            dev.write_model(new)
            total = board.counters["eeprom_writes"] - before
    return image, old, new, total


def _positions(total: int) -> list[int]:
    # The first writes (the other slot's magic, the first blob bytes), the middle of the blob,
    # every byte of the slot header (its last 8 writes, magic last) and one past the end.
    return sorted({1, 2, total // 2} | set(range(total - 8, total + 2)))


def test_power_loss_at_write_k_keeps_the_old_model(simboard_cls, start_image, tmp_path):
    image, old, new, total = start_image
    assert total > len(new)  # the blob and the slot header, at least
    x = np.clip(np.cumsum(np.random.default_rng(5).normal(0, 300, (64, 3)), axis=0), -9000, 4000).astype(np.int16)
    outcomes = {"old": 0, "new": 0}
    for k in _positions(total):
        path = tmp_path / f"ee{k}.bin"
        shutil.copy(image, path)
        with simboard_cls(elf=str(ELF), eeprom=path) as board:
            with Device.open(board.url, timeout_scale=5.0) as dev:
                resets = board.counters["resets"]
                board.reset_after_eeprom_writes(k)
                # A write the board resets under is never answered: the host gives up after the
                # command's own deadline instead of five of them (a late answer before the reset
                # is retried with the same sequence number and answered from the board's cache).
                dev.timeout_scale = 1.0 if k <= total else 5.0
                try:
                    dev.write_model(new)
                except DeviceError:
                    pass  # the board reset under the write
                dev.timeout_scale = 5.0
                board.reset_after_eeprom_writes(0)
                torn = board.counters["resets"] > resets
                assert torn == (k <= total), f"write {k} of {total}: reset happened {torn}"
                dev.hello(wait_s=5.0)
                info = dev.model_info()
                assert info.valid, f"power loss at write {k} of {total}: no model ({info})"
                is_new = info.crc == blob_crc(new)
                assert is_new or info.crc == blob_crc(old), f"write {k}: unknown model {info}"
                assert not is_new or k >= total, f"write {k} of {total}: new model before its last byte"
                assert np.array_equal(dev.replay(x), reference_run(new if is_new else old, x)), f"write {k}"
                outcomes["new" if is_new else "old"] += 1
    print(f"torn writes at {len(_positions(total))} of {total} positions on the simboard: {outcomes}")
    assert outcomes == {"old": len(_positions(total)) - 2, "new": 2}


def test_paper_wh_set_flashes_and_replays_bit_exact(simboard_cls, tmp_path):
    """The paper's 3-DoF estimator (three 3-input WH models, 2 poles per block, 10 breakpoints;
    compact tables) on the real firmware: stored, then replayed bit for bit, and a second write
    of another model beside it is refused for room while the set keeps running."""
    from porosense.errors import ModelError
    from porosense.quant import quantize
    from porosense.quant.random_models import random_structure

    s = random_structure(np.random.default_rng(0), 3, 3, h1_poles=2, h2_poles=2, breakpoints=10, kind="wh")
    paper = quantize(s).blob.to_bytes()
    assert len(paper) <= MAX_BLOB_LEN  # the EEPROM model area
    x = np.clip(np.cumsum(np.random.default_rng(6).normal(0, 300, (200, 3)), axis=0), -9000, 4000).astype(np.int16)
    with simboard_cls(elf=str(ELF), eeprom=tmp_path / "ee.bin") as board:
        with Device.open(board.url, timeout_scale=5.0) as dev:
            info = dev.write_model(paper)
            assert info.valid and info.n_outputs == 3 and info.length == len(paper)
            assert np.array_equal(dev.replay(x), reference_run(paper, x))
            with pytest.raises(ModelError, match="does not fit beside"):
                dev.write_model(make_blob(3), replace=False)
            assert dev.model_info().crc == blob_crc(paper)
            dev.reset()
            assert dev.model_info().crc == blob_crc(paper)
            assert np.array_equal(dev.replay(x), reference_run(paper, x))
