"""``porosense bench ident`` at CI size: the figures exist and the fits hold (no timing asserts)."""

import pytest

from porosense.bench import ident as bench_ident


@pytest.mark.bench
def test_bench_ident_small():
    r = bench_ident.run("small")
    print("\n".join(r["summary"]))
    assert r["parts"] == list(bench_ident.SMALL_PARTS)
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
    if "oe_narx_fit" in r:  # the OE truth is linear: a NARX cannot simulate it better than OE
        assert r["oe_porosense_fit"] >= r["oe_narx_fit"] - 0.01
    if isinstance(r.get("cluster"), dict):  # Dask installed: 1 and 2 workers give the local pool's model
        assert [row["workers"] for row in r["cluster"]["rows"]] == ["local pool", 1, 2]
        assert all(row["same_model"] for row in r["cluster"]["rows"])


def test_bench_ident_refuses_an_unknown_part():
    from porosense.errors import InputError

    with pytest.raises(InputError, match="unknown bench ident part"):
        bench_ident.run("small", only=["gird"])
