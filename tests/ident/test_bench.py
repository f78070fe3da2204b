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


def _test_output_spread(folder) -> float:
    """Standard deviation of the test multisine's output past the transient, V: the RMSE of
    predicting its mean, which any model of the system must beat."""
    import numpy as np

    from porosense.bench.wh_noise import SKIP
    from porosense.data import read_table

    return float(np.std(read_table(folder / "wh_process_noise" / "WH_TestDataset.csv").columns["y_0"][SKIP:]))


@pytest.mark.bench
def test_bench_ident_builds_small(shared_data):
    """``bench ident --only builds`` on one realisation at 2 poles / 1 zero, 20 evaluations: every
    build is refined with a measured level, the tie rule keeps one, and every model predicts the
    measured test multisine better than its mean (measured: 36-55 mV against 129 mV of spread)."""
    from porosense.bench import wh_noise

    opts = wh_noise.Options(realisations=(0,), order=(2, 1), evaluations=20)
    r = bench_ident.run("small", only=["builds"], wh_noise=opts)
    print("\n".join(r["summary"]))
    b = r["wh_builds"]
    assert b["order"] == [2, 1] and b["realisations"] == [0]
    assert len(b["builds"]) == len(b["output_error_test_rmse_mV"]) >= 2
    assert sum(row["kept"] for row in b["builds"]) <= 1
    assert min(row["error_above_lowest_pct"] for row in b["builds"]) == 0.0
    assert all(row["level_per_spread"] > 0 for row in b["builds"])
    spread_mv = 1e3 * _test_output_spread(shared_data)
    assert all(row["test_rmse_mV"] < spread_mv for row in b["builds"])
    assert all(mv < spread_mv for mv in b["output_error_test_rmse_mV"].values())
    kept = [row for row in b["builds"] if row["kept"]]
    if kept:  # the kept build is at no distance from itself, and the deconvolution check ran
        assert kept[0]["from_kept_mV"] == 0.0
        assert b["deconvolution"]["tied_builds"] >= 1
    assert len(r["summary"]) == 1 + 2 * len(b["builds"]) + bool(kept)


@pytest.mark.bench
def test_bench_ident_whsearch_small(shared_data):
    """``bench ident --only whsearch`` on realisation 0 (1 validates), linear and WH at 2 poles, 10
    evaluations: the search runs with process noise, and every structure's best model and the
    selected one predict the test multisine better than its mean (measured: 40-45 mV against 129 mV)."""
    from porosense.bench import wh_noise

    opts = wh_noise.Options(realisations=(0,), structures=("linear", "wh"), poles=(2,), starts=1, evaluations=10)
    r = bench_ident.run("small", only=["whsearch"], wh_noise=opts)
    print("\n".join(r["summary"]))
    w = r["wh_search"]
    assert w["validation"] == 1 and w["poles"] == [2]
    assert set(w["best_per_structure"]) == {"linear", "wh"}
    assert w["selected"].split()[0] in w["best_per_structure"]
    spread_mv = 1e3 * _test_output_spread(shared_data)
    assert all(b["test_rmse_mV"] < spread_mv for b in w["best_per_structure"].values())
    assert w["selected_test_rmse_mV"] < spread_mv


@pytest.mark.parametrize(
    "argv",
    [
        ["--only", "builds", "--realisations", "0"],
        ["--only", "builds", "--realisations", "3-12"],
        ["--only", "builds", "--order", "3,3"],
        ["--only", "builds", "--order", "six"],
        ["--only", "whsearch", "--structures", "narx"],
        ["--only", "whsearch", "--starts", "0"],
    ],
)
def test_bench_ident_wh_noise_refuses_bad_options(argv, capsys):
    from porosense.cli import main

    assert main(["bench", "ident", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]


def test_bench_wh_noise_options_belong_to_ident(capsys):
    from porosense.cli import main

    assert main(["bench", "protocol", "--order", "6,3"]) == 2
    assert "belong to 'porosense bench ident'" in capsys.readouterr().err
