"""``porosense bench ident`` at CI size: the figures exist and the fits hold (no timing asserts)."""

import pytest

from porosense.bench import ident as bench_ident


@pytest.mark.bench
def test_bench_ident_small():
    r = bench_ident.run("small")
    print("\n".join(r["summary"]))
    assert r["grid_models"] == 4 * 3
    # Truth is WH (1 + 2 poles) with small output noise; poles <= 2 cannot match it exactly.
    assert r["grid_best_fit"] > 90.0
    assert r["grid_best_fit_per_structure"]["wh"] >= r["grid_best_fit_per_structure"]["linear"]
    assert r["oe_porosense_fit_noise_free"] > 99.0
    # Time against samples: every size ran and selected a model that validates well.
    assert [row["samples"] for row in r["scaling"]] == [2_000, 5_000]
    assert all(row["cpu_s"] > 0 and row["validation_fit"] > 80.0 for row in r["scaling"])
    if "oe_sippy_fit" in r:
        assert r["oe_porosense_fit"] >= r["oe_sippy_fit"] - 0.01
