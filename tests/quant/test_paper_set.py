"""The paper's 3-DoF estimator (three 3-input WH models, f + H1 + g + H2, 2 poles per block,
10 breakpoints) fits the board's model area with compact tables, and loses nothing measurable
to them. Random structures at the paper's orders (independent draws, fixed seeds), inputs over
the whole -100..100 % range so that every breakpoint is kept."""

import numpy as np
import pytest

from porosense.protocol.model_blob import MAX_BLOB_LEN, ModelBlob
from porosense.quant import FixedPointEstimator, fit_percent, quantize
from porosense.quant.design import blob_size, compact_tables, design_blob
from porosense.quant.random_models import random_structure, step_inputs

SEEDS = range(6)


def paper_structure(seed):
    return random_structure(np.random.default_rng(seed), 3, 3, h1_poles=2, h2_poles=2, breakpoints=10, kind="wh")


@pytest.mark.parametrize("seed", SEEDS)
def test_paper_set_fits_with_compact_tables(seed):
    s = paper_structure(seed)
    full, _ = design_blob(s, [(-100.0, 100.0)] * 3, 0.01, 0, [])
    assert full.length > MAX_BLOB_LEN  # the full encoding does not fit: 1,087..1,093 bytes
    q = quantize(s)
    tables = [b.f for o in q.blob.outputs for b in o.branches] + [o.g for o in q.blob.outputs]
    assert all(t is not None and t.compact and len(t.x) == 10 for t in tables)
    assert q.blob.length <= MAX_BLOB_LEN and q.blob.length == full.length - 12 * 27
    assert blob_size(s) <= q.blob.length <= blob_size(s, section_bytes=20.0)  # 16- or 32-bit numerators
    assert any(n.startswith("compact tables") for n in q.report.notes)
    assert ModelBlob.from_bytes(q.blob.to_bytes()) == q.blob


@pytest.mark.parametrize("seed", SEEDS)
def test_compact_tables_cost_no_more_than_the_fixed_point_loss_itself(seed):
    """Against the float model on the device's own inputs, a compact table's error is a rounding
    of its breakpoint values, as in the full encoding: its fit loss stays within 10 % (+0.1
    point) of the full encoding's own fixed-point loss, and above 95 % (the full encoding's
    worst over these draws is 96.1 %)."""
    s = paper_structure(seed)
    rng = np.random.default_rng(100 + seed)
    u = step_inputs(rng, 3000, 3)
    counts = np.round(u * 100).astype(np.int64)
    y_float = s.simulate(counts * 0.01)
    full, _ = design_blob(s, [(-100.0, 100.0)] * 3, 0.01, 0, [])
    for j in range(3):
        fits = []
        for blob in (full, compact_tables(full)):
            est, flags = FixedPointEstimator(blob).run(counts)
            fits.append(fit_percent(y_float[:, j], est[:, j] * blob.out_scale[j]))
        assert 100.0 - fits[1] <= 1.1 * (100.0 - fits[0]) + 0.1, fits
        assert fits[1] >= 95.0, fits
