"""porosense bench quant at CI size: the non-timing figures (fit loss, sizes, AVR cycles in simavr)."""

import pytest

from porosense.bench import quant as bench
from porosense.protocol.model_blob import MAX_BLOB_LEN

# One worker runs the module: the figures are a module fixture a second worker would compute again.
pytestmark = [pytest.mark.bench, pytest.mark.xdist_group("quant-bench")]


@pytest.fixture(scope="module")
def figures():
    return bench.run("small")


def test_fit_and_size_figures(figures):
    assert figures["max_fit_loss_points"] <= 0.5
    assert figures["saturated_samples"] == 0
    assert "bytes too large" in figures["worst_case_refusal"]
    assert figures["largest_fitting_3dof"]["blob_bytes"] <= MAX_BLOB_LEN
    # The paper's 3-DoF set fits a flash slot (compact tables), twice in the store.
    paper = figures["paper_3dof_set"]
    assert paper["flash_slot_bytes"][1] <= paper["flash_slot_capacity"] < paper["full_tables_bytes"][0]
    assert figures["summary"] and all(isinstance(line, str) for line in figures["summary"])


def test_avr_estimator_is_bit_exact_and_within_budget_from_eeprom(figures):
    avr = figures["avr"]
    if "skipped" in avr:
        pytest.skip(avr["skipped"])
    assert avr["worst_case_bit_exact"] and avr["eeprom_model_bit_exact"] and avr["eeprom_most_sections_bit_exact"]
    assert avr["eeprom_model_cycles"] <= bench.CYCLE_BUDGET
    assert avr["estimator_ram_bytes"] <= 700


def test_storable_worst_case_within_budget(figures):
    """The storable model with the most sections (read from the EEPROM as on the device): the
    real worst case of a stored model."""
    avr = figures["avr"]
    if "skipped" in avr:
        pytest.skip(avr["skipped"])
    assert avr["eeprom_most_sections_bit_exact"]
    assert avr["eeprom_most_sections_cycles"] <= bench.CYCLE_BUDGET


def test_controlled_sample_within_budget(figures):
    """The strain controller on 3 channels after the storable model with the most sections:
    both together within the per-sample cycle budget."""
    avr = figures["avr"]
    if "skipped" in avr:
        pytest.skip(avr["skipped"])
    print(
        f"controller {avr['control_cycles']} cycles; with the estimator "
        f"{avr['eeprom_most_sections_with_control_cycles']} of {bench.CYCLE_BUDGET}"
    )
    assert 0 < avr["control_cycles"] <= avr["eeprom_most_sections_with_control_cycles"]
    assert avr["eeprom_most_sections_with_control_cycles"] <= bench.CYCLE_BUDGET


@pytest.mark.xfail(
    strict=True,
    reason="known gap: the nominal worst case (3x3, 10+10 poles, 16 breakpoints, a "
    "2.3 KB blob that cannot be stored, read from flash with memcpy_P) takes about 51,600 cycles "
    "(65,100 before the assembly cascade); about 13,000 of them are the blob reads",
)
def test_nominal_worst_case_within_budget(figures):
    avr = figures["avr"]
    if "skipped" in avr:
        pytest.skip(avr["skipped"])
    assert avr["worst_case_bit_exact"]
    assert avr["worst_case_cycles"] <= bench.CYCLE_BUDGET


def test_paper_set_from_the_flash_store_within_budget():
    """The paper's 3-DoF set as a 1,016-byte flash slot holds it (compact tables), read from
    flash: bit-exact and inside the 48,000-cycle budget."""
    import numpy as np

    from porosense.firmware import avr_cycles
    from porosense.protocol import model_layout as L
    from porosense.quant import quantize
    from porosense.quant.random_models import random_structure

    if avr_cycles.available():
        pytest.skip(f"missing: {avr_cycles.available()}")
    s = random_structure(np.random.default_rng(0), 3, 3, h1_poles=2, h2_poles=2, breakpoints=10, kind="wh")
    blob = quantize(s, input_range=(-90.0, 10.0), capacity=L.FLASH_BLOB_MAX, noise_lsb=0).blob
    r = avr_cycles.measure(blob, in_eeprom=False)
    print(f"paper 3-DoF set, {blob.length} B, from flash: {r.max_cycles} cycles (mean {r.mean_cycles})")
    assert blob.length <= L.FLASH_BLOB_MAX and r.bit_exact
    assert r.max_cycles <= bench.CYCLE_BUDGET


def test_heaviest_flash_slot_model_within_budget():
    """The heaviest model a 1,016-byte flash slot holds (porosense.bench.firmware
    .heaviest_storable_blob, 927 B), read from flash: bit-exact, within the cycle budget
    (36,850 cycles measured; with the 1,144-byte slots it was a 1,129 B model at 56,392)."""
    from porosense.bench import firmware as fw
    from porosense.firmware import avr_cycles

    if avr_cycles.available():
        pytest.skip(f"missing: {avr_cycles.available()}")
    blob = fw.heaviest_storable_blob()
    r = avr_cycles.measure(blob, in_eeprom=False)
    print(f"heaviest flash-slot model, {len(blob)} B: {r.max_cycles} cycles")
    assert r.bit_exact
    assert r.max_cycles <= bench.CYCLE_BUDGET
