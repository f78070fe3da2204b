"""``porosense bench ident`` at CI size: the figures exist and the fits hold (no timing asserts)."""

import pytest

from porosense.bench import ident as bench_ident


@pytest.mark.bench
def test_bench_ident_small():
    r = bench_ident.run("small")
    print("\n".join(r["summary"]))
    assert r["grid_models"] == 4 * 3
    # Truth is WH with 0.05 % output noise: the selected model must be near-perfect.
    assert r["grid_best_fit"] > 97.0
    assert r["grid_best_fit_per_structure"]["wh"] >= r["grid_best_fit_per_structure"]["linear"]
    assert r["oe_porosense_fit_noise_free"] > 99.0
    if "oe_sippy_fit" in r:
        assert r["oe_porosense_fit"] >= r["oe_sippy_fit"] - 0.01
