"""The 3-DoF demo's path in its parts, with small sizes: the paper's 3-DoF experiments
simulated (porosense.sim, independent of the identification and the firmware), shortened;
every output identified at the paper's orders (WH, 2 poles, 1 zero, 10 breakpoints) and the WH
model kept; the 3-output set quantized, stored on the simboard (the flash store: with full
tables it exceeds the EEPROM) and verified by replay bit for bit; a torn upload of the next set
leaves it running. The whole `porosense demo --actuator 3dof --board simboard` records on the
board for tens of minutes; these are its steps on simulated recordings."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from porosense.protocol import model_layout as L
from porosense.workflows import demo

ROOT = Path(__file__).resolve().parents[2]
ELF = ROOT / "firmware" / "build" / "porosense.elf"
RATE_HZ = 50
SECONDS = 200  # of each experiment: all of it (the 3-DoF experiments run 60-80 s)
# One worker runs the module: split over two, each identified the three outputs itself.
pytestmark = pytest.mark.xdist_group("demo-3dof-parts")


@pytest.fixture(scope="module")
def recordings():
    from porosense.sim import run_experiment

    est, val = demo.PROTOCOL["3dof"]
    recs = {}
    for k, exp in enumerate(est + val):
        rec = run_experiment("3dof", exp, rate_hz=RATE_HZ, seed=20 + k)
        recs[exp] = rec.slice(0.0, float(SECONDS))
    return recs, est, val


@pytest.fixture(scope="module")
def identified(recordings):
    recs, est, val = recordings
    lines = []
    t0 = time.perf_counter()
    searches, chosen = demo.identify_outputs(recs, "3dof", est, val, rate_hz=RATE_HZ, max_poles=3, log=lines.append)
    print(f"identified 3 outputs at the paper's orders in {time.perf_counter() - t0:.1f} s")
    return searches, chosen, lines


@pytest.mark.slow
def test_paper_orders_and_wh_kept(identified):
    searches, chosen, lines = identified
    assert any("WH at the paper's orders" in ln for ln in lines)
    for res, c in zip(searches, chosen):
        per = res.best_per_structure()
        assert set(per) == {"linear", "hammerstein", "wiener", "wh"}
        assert all((x.n_poles, x.n_zeros) == (2, 1) for x in per.values())
        assert c.structure == "wh" and c.model.n_breakpoints == 10
        print(f"{c.model.output}: " + ", ".join(f"{s} {x.mean_fit:.1f} %" for s, x in per.items()))
        # The WH candidate is refined from the Wiener and Hammerstein ones of its order.
        assert per["wh"].mean_fit >= max(per["wiener"].mean_fit, per["hammerstein"].mean_fit) - 0.5


@pytest.mark.slow
@pytest.mark.simboard
def test_quantize_store_in_flash_and_verify_on_the_simboard(recordings, identified):
    try:
        from porosense.simboard import SimBoard
        from porosense.simboard.board import harness_path
    except ImportError as exc:
        pytest.skip(f"porosense.simboard is not available ({exc})")
    if not ELF.is_file() or not Path(harness_path()).is_file():
        pytest.skip("firmware ELF or simboard harness not built")
    from porosense.device import Device
    from porosense.firmware.flash_store import SLOT_PAGES, plan_upload

    recs, est, val = recordings
    _, chosen, _ = identified
    structure, q = demo.quantize_model(chosen, recs, "3dof", val, RATE_HZ)
    blob = q.blob.to_bytes()
    print(f"3-output WH set: {len(blob)} bytes, worst fixed-point loss {q.report.worst_loss_points:.3f} points")
    assert len(structure.outputs) == 3 and q.blob.n_outputs == 3
    assert L.AREA_LEN < len(blob) <= L.FLASH_BLOB_MAX  # full tables: only the flash store holds it
    log = []
    with SimBoard(elf=str(ELF), actuator="3dof") as board, Device.open(board.url, timeout_scale=4.0) as dev:
        info = demo.store_model(dev, blob, board.program_flash, log=log.append)
        assert info.store == "flash" and info.length == len(blob)
        verify = demo.verify_by_replay(dev, q.blob, recs[val[0]], SIGNALS_IN, log=log.append)
        assert verify["bit_exact"] and verify["samples"] >= 1000
        # A torn upload of the next set leaves this one running.
        board.program_flash(plan_upload(blob, dev.model_info()).pages(), n_pages=SLOT_PAGES - 1)
        dev.after_reset()
        again = dev.model_info()
        assert (again.slot, again.crc) == (info.slot, info.crc)
    print("\n".join(log))


SIGNALS_IN = demo.SIGNALS["3dof"][0]
