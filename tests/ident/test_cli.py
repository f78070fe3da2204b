"""The identify and predict commands, driven as the project's checks drive them."""

import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import read_table
from porosense.ident import fit_percent


@pytest.fixture
def csv_files(tmp_path, truth, make_recordings):
    """Two recordings of the Wiener truth as CSV with a trailing comma on every line."""
    system = truth("wiener")
    us, ys, _ = make_recordings(system, 800, seeds=(21, 22))
    paths = []
    for k, (u, y) in enumerate(zip(us, ys)):
        p = tmp_path / f"rec{k}.csv"
        t = np.arange(len(y)) * system.ts
        lines = ["t,dR_0,strain_0,"] + [
            f"{a!r},{b!r},{c!r}," for a, b, c in zip(t.tolist(), u[:, 0].tolist(), y.tolist())
        ]
        p.write_text("\n".join(lines) + "\n")
        paths.append(p)
    return paths


def test_identify_then_predict(csv_files, tmp_path, capsys):
    model, report, pred = tmp_path / "model.json", tmp_path / "report.json", tmp_path / "pred.csv"
    rc = main(
        [
            "identify",
            "--data",
            *map(str, csv_files),
            "--input",
            "dR_0",
            "--output",
            "strain_0",
            "--ts",
            "0.02",
            "--structure",
            "wiener",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--breakpoints",
            "5",
            "--estimation",
            "0:500",
            "--validation",
            "500:",
            "--out",
            str(model),
            "--json-out",
            str(report),
            "--quiet",
        ]
    )
    assert rc == 0
    rep = json.loads(report.read_text())
    best = rep["results"][0]["best"]
    assert best["structure"] == "wiener" and min(best["fit_validation"]) > 99.0
    assert main(["predict", "--model", str(model), "--data", str(csv_files[1]), "--out", str(pred)]) == 0
    out = read_table(pred)
    src = read_table(csv_files[1])
    assert out.names == ["t", "strain_0_pred"]
    assert fit_percent(src.columns["strain_0"], out.columns["strain_0_pred"]) > 99.0


def test_identify_reports_a_missing_column_in_one_line(csv_files, tmp_path, capsys):
    rc = main(
        [
            "identify",
            "--data",
            str(csv_files[0]),
            "--input",
            "dR_9",
            "--output",
            "strain_0",
            "--ts",
            "0.02",
            "--structure",
            "linear",
            "--poles",
            "1",
            "--out",
            str(tmp_path / "m.json"),
        ]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "dR_9" in err[0]


def test_bad_range_is_a_user_error(csv_files, tmp_path, capsys):
    rc = main(
        [
            "identify",
            "--data",
            str(csv_files[0]),
            "--input",
            "dR_0",
            "--output",
            "strain_0",
            "--ts",
            "0.02",
            "--structure",
            "linear",
            "--poles",
            "1",
            "--estimation",
            "a:b",
            "--out",
            str(tmp_path / "m.json"),
        ]
    )
    assert rc == 2 and "sample range" in capsys.readouterr().err


def test_predict_on_a_missing_model_file(tmp_path, csv_files, capsys):
    rc = main(
        [
            "predict",
            "--model",
            str(tmp_path / "none.json"),
            "--data",
            str(csv_files[0]),
            "--out",
            str(tmp_path / "p.csv"),
        ]
    )
    assert rc == 4 and "not found" in capsys.readouterr().err


def _identify(files, tmp_path, *extra):
    return main(
        [
            "identify",
            "--data",
            *map(str, files),
            "--input",
            "dR_0",
            "--output",
            "strain_0",
            "--ts",
            "0.02",
            "--structure",
            "linear",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--out",
            str(tmp_path / "m.json"),
            "--quiet",
            *extra,
        ]
    )


def test_default_selection_holds_out_the_last_quarter_and_prints_the_rule(csv_files, tmp_path, capsys):
    assert _identify(csv_files, tmp_path, "--json-out", str(tmp_path / "r.json")) == 0
    out = capsys.readouterr().out
    assert "hold-out: the last 25 % of every file" in out
    assert "selected row: linear" in out and "validation fit" in out and "rule:" in out
    best = json.loads((tmp_path / "r.json").read_text())["results"][0]["best"]
    # Two recordings, each scored on its own last quarter (200 of 800 samples).
    assert len(best["fit_validation"]) == 2 and len(best["fit_estimation"]) == 2


def test_three_files_leave_the_last_one_out(csv_files, tmp_path, capsys):
    third = tmp_path / "rec2.csv"
    third.write_text(csv_files[0].read_text())
    assert _identify([*csv_files, third], tmp_path, "--json-out", str(tmp_path / "r.json")) == 0
    assert "the last file" in capsys.readouterr().out
    best = json.loads((tmp_path / "r.json").read_text())["results"][0]["best"]
    assert len(best["fit_estimation"]) == 2 and len(best["fit_validation"]) == 1


def test_validation_data_files_and_criterion(csv_files, tmp_path, capsys):
    assert (
        _identify(
            csv_files[:1],
            tmp_path,
            "--validation-data",
            str(csv_files[1]),
            "--criterion",
            "bic",
            "--json-out",
            str(tmp_path / "r.json"),
        )
        == 0
    )
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["criterion"] == "bic" and "lowest BIC" in rep["results"][0]["rule"]
    assert min(rep["results"][0]["best"]["fit_validation"]) > 60.0


@pytest.mark.parametrize(
    "extra, words",
    [
        (("--criterion", "r2"), "criterion"),
        (("--validation-data", "MISSING_COLUMNS"), "no column"),
        (("--estimation", "0:40"), "too short"),
    ],
)
def test_selection_input_errors_are_one_line(csv_files, tmp_path, capsys, extra, words):
    if "MISSING_COLUMNS" in extra:
        bad = tmp_path / "other.csv"
        bad.write_text("t,x\n0,1\n0.02,2\n")
        extra = ("--validation-data", str(bad))
    rc = _identify(csv_files, tmp_path, *extra)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and words in err[0]


def test_identify_process_noise_then_predict_expected(csv_files, tmp_path, capsys):
    """--process-noise saves a Wiener model with a noise at g's input (its fit on this
    noise-free truth stays above 99 %); predict gives the noise-free output, --expected the
    noise-averaged one, and --expected on a model without process noise is one line, exit 2."""
    model, pred = tmp_path / "model.json", tmp_path / "pred.csv"
    rc = main(
        [
            "identify",
            "--data",
            *map(str, csv_files),
            "--input",
            "dR_0",
            "--output",
            "strain_0",
            "--ts",
            "0.02",
            "--structure",
            "wiener",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--breakpoints",
            "5",
            "--estimation",
            "0:500",
            "--validation",
            "500:",
            "--process-noise",
            "--smoothness",
            "0",
            "--out",
            str(model),
            "--quiet",
        ]
    )
    assert rc == 0
    doc = json.loads(model.read_text())["models"][0]
    assert doc["options"]["process_noise"] is True and doc["spec"]["g_noise"] is True
    src = read_table(csv_files[1])
    for extra in ([], ["--expected"]):
        # the second pass replaces the first pass's output, which predict refuses without --force
        args = ["predict", "--model", str(model), "--data", str(csv_files[1]), "--out", str(pred), "--force", *extra]
        assert main(args) == 0
        assert fit_percent(src.columns["strain_0"], read_table(pred).columns["strain_0_pred"]) > 99.0
    plain = tmp_path / "plain.json"
    assert (
        main(
            [
                "identify",
                "--data",
                *map(str, csv_files),
                "--input",
                "dR_0",
                "--output",
                "strain_0",
                "--ts",
                "0.02",
                "--structure",
                "linear",
                "--poles",
                "1",
                "--out",
                str(plain),
                "--quiet",
            ]
        )
        == 0
    )
    capsys.readouterr()
    rc = main(["predict", "--model", str(plain), "--data", str(csv_files[1]), "--expected"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "process noise" in err[0]
