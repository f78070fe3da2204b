"""The mistakes that used to end with exit 0 and a wrong result (issue 32), each as a user makes it.

Every refusal is checked for its exit code, one line on stderr naming the problem, and that no
output file was written (or an existing one changed). The recordings come from an independent
generator: a first-order lag (pole 0.9) of a random staircase, with noise, at 50 Hz.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from porosense import ident
from porosense.cli import main
from tests.data.matlab_files import write_mat_v5

RATE_HZ = 50.0


def _signals(n=1500, seed=5):
    from scipy import signal

    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-80, 0, n // 50), 50)
    y = signal.lfilter([0.03], [1, -0.9], -u) + rng.normal(0, 0.02, n)
    return u, y


def _write(path, t, u, y, header="t,dR_0,strain_0", units_row=None):
    lines = [header] + ([units_row] if units_row else [])
    lines += [f"{a!r},{b!r},{c!r}" for a, b, c in zip(np.asarray(t, float).tolist(), u.tolist(), y.tolist())]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("silent")
    u, y = _signals()
    t = np.arange(len(u)) / RATE_HZ
    _write(d / "run.csv", t, u, y)
    _write(d / "run_ms.csv", t * 1000, u, y)
    _write(d / "run_time_ms.csv", t * 1000, u, y, header="time_ms,dR_0,strain_0")
    _write(d / "run_time.csv", t * 1000, u, y, header="time,dR_0,strain_0")
    write_mat_v5(d / "run_ms.mat", {"t": t * 1000, "dR_0": u, "strain_0": y})
    back = t.copy()
    back[[800, 801]] = back[[801, 800]]
    _write(d / "back.csv", back, u, y)
    _write(d / "near_const.csv", t, -20.0 + np.random.default_rng(1).normal(0, 1e-6, len(u)), y)
    _write(d / "ohms.csv", t, 1000.0 + 3.0 * u, y, header="t,R_0,strain_0")  # a resistance in ohms
    _write(d / "run_20hz.csv", np.arange(len(u)) / 20.0, u, y)
    gap = t.copy()
    gap[900:] += 0.2
    _write(d / "gap.csv", gap, u, y)
    dup = np.insert(t, 700, t[700])
    _write(d / "dup.csv", dup, np.insert(u, 700, u[700]), np.insert(y, 700, y[700]))
    _write(d / "const.csv", t, np.full_like(u, -20.0), y)
    (d / "header_only.csv").write_text("t,dR_0,strain_0\n")
    m = ident.make_model("linear", n_poles=1, n_zeros=0).fit(
        u=u[:, None], y=y, ts=1 / RATE_HZ, inputs=("dR_0",), output="strain_0"
    )
    m.save(d / "model.json")
    ident.make_model("linear", n_poles=1, n_zeros=0).fit(
        u=(1000.0 + 3.0 * u)[:, None], y=y, ts=1 / RATE_HZ, inputs=("R_0",), output="strain_0"
    ).save(d / "ohm_model.json")
    return d


def _run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err.strip()


def _identify(d, data, out, *extra):
    return ["identify", "--data", *data, "--input", "dR_0", "--output", "strain_0"] + [
        "--structure",
        "linear",
        "--poles",
        "1",
        "--zeros",
        "0",
        "--out",
        out,
        *extra,
    ]


@pytest.mark.parametrize("name", ["run_ms.csv", "run_time.csv", "run_time_ms.csv", "run_ms.mat"])
def test_time_in_ms_makes_a_50_hz_model_and_a_50_hz_blob(work, capsys, name):
    out = work / f"m_{name}.json"
    rc, text, err = _run(capsys, _identify(work, [work / name], out))
    assert rc == 0, err
    assert "in ms" in text  # the unit used is stated
    assert json.loads(out.read_text())["models"][0]["ts"] == pytest.approx(1 / RATE_HZ)
    rc, text, err = _run(capsys, ["quantize", "--model", out, "--out", work / f"{name}.bin"])
    assert rc == 0 and "50 Hz" in text, err


@pytest.mark.parametrize(
    "data,extra,words",
    [
        ("gap.csv", [], ["line 902", "gap of 0.22 s", "--resample"]),
        ("dup.csv", [], ["line 703", "repeats", "--resample"]),
        ("header_only.csv", [], ["no data rows"]),
        ("back.csv", [], ["line 803", "goes back", "out of order"]),
        ("const.csv", [], ["input 'dR_0' is constant at -20", "16-bit"]),
        ("near_const.csv", [], ["input 'dR_0' varies by only", "around -20", "16-bit"]),
        ("run.csv", ["--input", "strain_0"], ["both an input and an output"]),
    ],
)
def test_identify_refuses_and_writes_nothing(work, capsys, data, extra, words):
    out = work / "refused.json"
    argv = _identify(work, [work / data], out)
    if extra:
        argv[argv.index("--input") + 1] = extra[1]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert all(w in err for w in words), err
    assert not out.exists()


def test_resample_fills_the_gap_and_says_so(work, capsys):
    out = work / "resampled.json"
    rc, text, err = _run(capsys, _identify(work, [work / "gap.csv"], out, "--resample"))
    assert rc == 0, err
    assert "resampled 1500 samples onto 1510 at 20 ms" in text and out.is_file()


@pytest.mark.parametrize(
    "argv",
    [
        ["predict", "--model", "{d}/model.json", "--data", "{d}/run_20hz.csv"],
        ["compare", "--model", "{d}/model.json", "--data", "{d}/run_20hz.csv"],
        ["report", "--model", "{d}/model.json", "--data", "{d}/run_20hz.csv", "--out", "{d}/rep20"],
        ["quantize", "--model", "{d}/model.json", "--data", "{d}/run_20hz.csv", "--out", "{d}/q20.bin"],
        ["diagnose", "--model", "{d}/model.json", "--data", "{d}/run_20hz.csv"]
        + ["--input", "dR_0", "--output", "strain_0", "--out", "{d}/diag20"],
    ],
    ids=lambda a: a[0],
)
def test_a_50_hz_model_on_20_hz_data_is_refused_everywhere(work, capsys, argv):
    argv = [a.replace("{d}", str(work)) for a in argv]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert "50 Hz" in err and "20 Hz" in err, err
    for path in ("rep20", "q20.bin", "diag20"):
        assert not (work / path).exists()


def test_data_without_time_takes_the_models_period_and_says_so(work, capsys):
    u, y = _signals()
    (work / "notime.csv").write_text(
        "dR_0,strain_0\n" + "\n".join(f"{a!r},{b!r}" for a, b in zip(u.tolist(), y.tolist())) + "\n"
    )
    rc, text, err = _run(capsys, ["predict", "--model", work / "model.json", "--data", work / "notime.csv"])
    assert rc == 0, err
    assert "no time column" in text and "taking the model's 20 ms (50 Hz)" in text


def test_one_fit_number_from_predict_compare_and_report(work, capsys):
    """The same model on the same file: the same fit to the printed digit, everywhere."""
    rc, text, err = _run(capsys, ["predict", "--model", work / "model.json", "--data", work / "run.csv", "--json"])
    assert rc == 0, err
    fit_predict = json.loads(text)["scores"]["strain_0"]["fit"]
    rc, text, err = _run(capsys, ["compare", "--model", work / "model.json", "--data", work / "run.csv", "--json"])
    fit_compare = json.loads(text)["per_file"][0]["strain_0"]["fit"]
    rc2, text2, err2 = _run(
        capsys, ["report", "--model", work / "model.json", "--data", work / "run.csv", "--out", work / "rep1"]
    )
    assert rc == 0 and rc2 == 0, err + err2
    table1 = (work / "rep1" / "report.md").read_text()
    assert fit_predict == pytest.approx(fit_compare, abs=1e-12)
    assert f"{fit_predict:.2f}" in table1 or f"{fit_predict:.1f}" in table1
    assert 0 < fit_predict < 100  # a real score: the generator's noise keeps it below 100


def test_diagnose_prints_predicts_fit_first_on_the_same_file(work, capsys):
    """One file split 60/40 by diagnose: its first fit is the nominal model on the whole file,
    every sample simulated from rest (predict's number), then the validation-record fits, named."""
    rc, text, err = _run(capsys, ["predict", "--model", work / "model.json", "--data", work / "run.csv", "--json"])
    assert rc == 0, err
    scores = json.loads(text)["scores"]["strain_0"]
    argv = ["diagnose", "--model", work / "model.json", "--data", work / "run.csv", "--input", "dR_0"]
    rc, text, err = _run(capsys, [*argv, "--output", "strain_0", "--json-out", work / "diag1.json"])
    assert rc == 0, err
    rest = json.loads((work / "diag1.json").read_text())["nominal_from_rest"]
    print(f"\npredict {scores['fit']:.6f} %, diagnose {rest[0]['fit']:.6f} %")
    assert len(rest) == 1 and rest[0]["data"].endswith("run.csv")
    assert abs(rest[0]["fit"] - scores["fit"]) < 1e-9 and abs(rest[0]["rms"] - scores["rms"]) < 1e-9
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("nominal model on"))
    assert f"fit {scores['fit']:.2f} %" in lines[first] and "every sample" in lines[first]
    assert lines[first + 1].startswith("nominal model on the validation records")
    assert lines[first + 2].startswith("corrected model")
    assert not [line for line in lines if " nan" in line]  # a t that cannot be computed is "n/a"


def test_a_model_of_resistance_in_ohms_is_not_quantized(work, capsys):
    """The board feeds its model dR in 16-bit counts of 0.01 % (+-327.67 %): a model identified on
    ohms (inputs near 1000) is refused, exit 4, and an existing blob is left as it was, --force or not."""
    blob = work / "ohm.bin"
    argv = ["quantize", "--model", work / "ohm_model.json", "--out", blob]
    for extra in ([], ["--force"]):
        rc, _, err = _run(capsys, [*argv, *extra])
        assert rc == 4 and len(err.splitlines()) == 1, err
        assert "input R_0 reached" in err and "beyond the board's input range of +-327.67" in err, err
        if not extra:
            assert not blob.exists()
            blob.write_bytes(b"an older blob")  # --force allows replacing it, not quantizing the model
        else:
            assert blob.read_bytes() == b"an older blob"


def test_data_in_ohms_are_refused_by_quantize(work, capsys):
    out = work / "ohm_data.bin"
    argv = ["quantize", "--model", work / "model.json", "--data", work / "ohms.csv", "--input", "R_0", "--out", out]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert "ohms.csv: input dR_0 reaches" in err and "beyond the board's input range" in err, err
    assert not out.exists()


def test_a_period_in_ms_given_as_seconds_is_told_and_its_blob_refused(work, capsys):
    """Data without a time column and --ts 20 (meant as ms): identify says the rate is not a
    recording's; quantize refuses a blob the board cannot run (10..135 Hz), exit 4, unless --force."""
    u, y = _signals()
    (work / "no_t.csv").write_text(
        "dR_0,strain_0\n" + "\n".join(f"{a!r},{b!r}" for a, b in zip(u.tolist(), y.tolist())) + "\n"
    )
    model = work / "m_ts20.json"
    rc, _, err = _run(capsys, _identify(work, [work / "no_t.csv"], model, "--ts", "20", "--quiet"))
    assert rc == 0 and err.splitlines() == [
        "porosense identify: warning: --ts 20 s is a rate of 0.05 Hz, outside the 1 Hz..2 kHz of a recording: "
        "--ts takes seconds (20 ms is --ts 0.02)"
    ], err
    blob = work / "m_ts20.bin"
    rc, _, err = _run(capsys, ["quantize", "--model", model, "--out", blob])
    assert rc == 4 and len(err.splitlines()) == 1, err
    assert "runs at 0.05 Hz" in err and "10..135 Hz" in err and not blob.exists(), err
    rc, text, err = _run(capsys, ["quantize", "--model", model, "--out", blob, "--force"])
    assert rc == 0 and "0.05 Hz" in text and "warning: forced past a refusal" in err and blob.is_file()


def test_a_time_column_in_us_is_not_taken_for_s_or_ms(work, capsys, tmp_path):
    u, y = _signals(600)
    _write(tmp_path / "us.csv", np.arange(600) * 20_000.0, u, y)
    argv = ["predict", "--model", work / "model.json", "--data", tmp_path / "us.csv"]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1 and "gives no sample rate a recording has" in err, err
    rc, text, err = _run(capsys, [*argv, "--time-unit", "us"])
    assert rc == 0 and "in us (--time-unit), Ts 20 ms (50 Hz)" in text, err


def test_control_tune_refuses_a_command_that_is_not_a_pressure(work, capsys):
    """control tune fits vacuum (kPa) to the output: a dR column in % (negative, so it passed the
    sign check) gave gains 'in kPa per unit' from a plant in %/kPa, exit 0."""
    out = work / "gains.json"
    argv = ["control", "tune", "--data", work / "run.csv", "--input", "dR_0", "--output", "strain_0", "--out", out]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1 and "column dR_0 is in %, not kPa" in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["predict", "--model", "{d}/unit_model.json", "--data", "{d}/{f}", "--out", "{d}/u_out.csv"],
        ["compare", "--model", "{d}/unit_model.json", "--data", "{d}/{f}", "--json-out", "{d}/u_out.json"],
        ["report", "--model", "{d}/unit_model.json", "--data", "{d}/{f}", "--out", "{d}/u_out"],
        ["quantize", "--model", "{d}/unit_model.json", "--data", "{d}/{f}", "--out", "{d}/u_out.bin"],
        ["diagnose", "--model", "{d}/unit_model.json", "--data", "{d}/{f}", "--input", "dR_0"]
        + ["--output", "strain_0", "--out", "{d}/u_out"],
    ],
    ids=lambda a: a[0],
)
@pytest.mark.parametrize("units,named", [("s,ohm,%", "column dR_0 is in ohm"), ("s,%,mm", "column strain_0 is in mm")])
def test_data_in_other_units_than_the_models_are_refused(work, capsys, argv, units, named):
    """A model that states its units (dR_0 and strain_0 in %) meets data whose units row states
    others: scored, reported or quantized as if they were the model's, they gave a fit with exit 0."""
    u, y = _signals(600)
    if not (work / "unit_model.json").exists():
        ident.make_model("linear", n_poles=1, n_zeros=0).fit(
            u=u[:, None], y=y, ts=1 / RATE_HZ, inputs=("dR_0",), output="strain_0", input_unit="%", output_unit="%"
        ).save(work / "unit_model.json")
    name = f"units_{units.replace(',', '_').replace('%', 'pct')}.csv"
    _write(work / name, np.arange(600) / RATE_HZ, u, y, units_row=units)
    rc, _, err = _run(capsys, [a.replace("{d}", str(work)).replace("{f}", name) for a in argv])
    assert rc == 2 and len(err.splitlines()) == 1 and named in err and "the model's" in err, err
    assert not list(work.glob("u_out*"))


def test_a_constant_output_has_no_fit_and_never_prints_nan(work, capsys):
    """A recording whose output never moves has no NRMSE fit: predict and compare print 'n/a'
    (compare printed 'nan' and 'nan±nan'); quantize and diagnose refuse it in one line."""
    u, y = _signals()
    _write(work / "flat_y.csv", np.arange(len(u)) / RATE_HZ, u, np.full_like(y, 1.0))
    data = ["--model", work / "model.json", "--data", work / "flat_y.csv"]
    for command in ("predict", "compare"):
        rc, text, err = _run(capsys, [command, *data])
        assert rc == 0 and "n/a" in text and "nan" not in text, text + err
    rc, _, err = _run(capsys, ["quantize", *data, "--out", work / "flat.bin"])
    assert rc == 4 and len(err.splitlines()) == 1 and "output is constant" in err and not (work / "flat.bin").exists()
    argv = ["diagnose", *data, "--input", "dR_0", "--output", "strain_0", "--out", work / "flat_diag"]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1 and "the output is constant at 1" in err, err
    assert not (work / "flat_diag").exists()


def test_a_file_stating_two_periods_is_refused(work, capsys, tmp_path):
    """A time column at 50 Hz with a .mat Ts of 50 ms, or a sidecar rate of 100 Hz: the column
    used to win without a word."""
    u, y = _signals(600)
    t = np.arange(600) / RATE_HZ
    write_mat_v5(tmp_path / "two.mat", {"t": t, "dR_0": u, "strain_0": y, "Ts": np.array([[0.05]])})
    _write(tmp_path / "side.csv", t, u, y)
    (tmp_path / "side.json").write_text(json.dumps({"meta": {"rate_hz": 100}, "units": {}}))
    for name, stated in (
        ("two.mat", "variable Ts in two.mat states 50 ms (20 Hz)"),
        ("side.csv", "side.json states 10 ms (100 Hz)"),
    ):
        out = tmp_path / f"{name}.pred.csv"
        argv = ["predict", "--model", work / "model.json", "--data", tmp_path / name, "--out", out]
        rc, _, err = _run(capsys, argv)
        assert rc == 2 and len(err.splitlines()) == 1, err
        assert "time column 't' steps 20 ms (50 Hz)" in err and stated in err and not out.exists(), err


def test_a_model_file_where_a_blob_or_a_recording_goes_is_named(work, capsys):
    """The model JSON given to verify or flash (which take a blob) or as --data: one line saying
    what it is (was 'not a porosense model blob (bad magic)' without a file, or 'line 3 ... is not
    a number')."""
    model = work / "model.json"
    for argv in (
        ["verify", "--port", "socket://127.0.0.1:1", "--model", model, "--data", work / "run.csv"],
        ["flash", "--port", "socket://127.0.0.1:1", "--model", model],
    ):
        rc, _, err = _run(capsys, argv)
        assert rc == 4 and len(err.splitlines()) == 1, err
        assert f"{model} is a model file (JSON), not a blob: quantize it first" in err, err
    rc, _, err = _run(capsys, ["predict", "--model", model, "--data", model])
    assert rc == 2 and len(err.splitlines()) == 1 and "a JSON file, not a recording" in err, err


def test_a_model_with_its_period_as_text_is_refused(work, capsys):
    doc = json.loads((work / "model.json").read_text())
    doc["models"][0]["ts"] = "0.02"
    (work / "ts_text.json").write_text(json.dumps(doc))
    out = work / "ts_text.csv"
    argv = ["predict", "--model", work / "ts_text.json", "--data", work / "run.csv", "--out", out]
    rc, _, err = _run(capsys, argv)
    assert rc == 4 and len(err.splitlines()) == 1 and 'is a string ("0.02")' in err, err
    assert not out.exists()


def test_a_title_above_the_header_asks_for_skip_rows(work, capsys):
    text = (work / "run.csv").read_text()
    (work / "titled.csv").write_text("Logger v1.2\nexported 2026-01-05\n" + text)
    argv = ["predict", "--model", work / "model.json", "--data", work / "titled.csv"]
    rc, _, err = _run(capsys, argv)
    assert rc == 2 and len(err.splitlines()) == 1 and "pass --skip-rows N" in err, err
    rc, text, err = _run(capsys, [*argv, "--skip-rows", "2"])
    assert rc == 0 and "fit" in text, err


def test_a_mat_recording_states_its_porosity_and_load_in_the_report(work, capsys):
    """A recording saved as .mat (Recording.to_mat) carries its metadata: the report's table of
    recordings prints its porosity and load, as for a CSV with its sidecar (not '?' or 'not stated')."""
    from porosense.data import Recording

    u, y = _signals()
    rec = Recording(np.arange(len(u)) / RATE_HZ, {"dR_0": u, "strain_0": y}, {"porosity": 82.0, "load_g": 0.0})
    rec.to_mat(work / "rec.mat")
    rc, _, err = _run(
        capsys, ["report", "--model", work / "model.json", "--data", work / "rec.mat", "--out", work / "rep_mat"]
    )
    assert rc == 0, err
    row = next(line for line in (work / "rep_mat" / "report.md").read_text().splitlines() if "| rec |" in line)
    assert row.endswith("| 82 | 0 |"), row


def test_binary_file_and_unequal_mat_vectors_are_named(work, capsys, tmp_path):
    (tmp_path / "model.bin").write_bytes(bytes(range(256)))
    rc, _, err = _run(capsys, ["predict", "--model", work / "model.json", "--data", tmp_path / "model.bin"])
    assert rc == 2 and "binary file" in err and "UnicodeDecodeError" not in err
    write_mat_v5(tmp_path / "r.mat", {"t": np.arange(100) * 0.02, "dR_0": np.ones(100), "strain_0": np.ones(99)})
    rc, _, err = _run(capsys, ["compare", "--model", work / "model.json", "--data", tmp_path / "r.mat"])
    assert rc == 2 and "'strain_0' has 99 samples where the other variables have 100" in err, err


def test_verify_reads_a_mat_file(work, capsys, tmp_path):
    """verify reads .mat data like every command (it used to say 'MATLAB files need the .mat suffix')."""
    u, y = _signals(400)
    write_mat_v5(tmp_path / "x.mat", {"t": np.arange(400) / RATE_HZ, "dR_0": u, "strain_0": y})
    assert main(["quantize", "--model", str(work / "model.json"), "--out", str(tmp_path / "m.bin")]) == 0
    capsys.readouterr()
    rc, _, err = _run(
        capsys,
        ["verify", "--port", "socket://127.0.0.1:1", "--model", tmp_path / "m.bin", "--data", tmp_path / "x.mat"],
    )
    assert rc == 3 and "MATLAB" not in err, err  # the data were read; the absent board is what failed


def test_quoted_decimal_commas_units_row_and_comments(work, capsys, tmp_path):
    u, y = _signals(600)
    rows = [f'"{k / RATE_HZ:.2f}","{a:.4f}","{b:.4f}"'.replace(".", ",") for k, (a, b) in enumerate(zip(u, y))]
    (tmp_path / "eu.csv").write_text("# logger export\nt,dR_0,strain_0\ns,%,%\n" + "\n".join(rows) + "\n")
    rc, text, err = _run(
        capsys, ["predict", "--model", work / "model.json", "--data", tmp_path / "eu.csv", "--decimal", ","]
    )
    assert rc == 0, err
    assert "units row" in text and "fit" in text


def test_verify_prints_the_same_fit_as_predict_for_the_boards_estimates(work, capsys):
    """verify --output scores the board's fixed-point estimates with the one fit; it differs from
    predict's float fit only by the blob's quantization (quantize bounds that loss; here 0.5 points)."""
    pytest.importorskip("porosense.emulator")
    from porosense.device import Device
    from porosense.emulator import Emulator

    assert main(["quantize", "--model", str(work / "model.json"), "--out", str(work / "v.bin")]) == 0
    capsys.readouterr()
    rc, text, err = _run(capsys, ["predict", "--model", work / "model.json", "--data", work / "run.csv", "--json"])
    fit_float = json.loads(text)["scores"]["strain_0"]["fit"]
    with Emulator(actuator="contractor") as emu:
        with Device.open(emu.url) as dev:
            dev.config_set("SAMPLE_RATE_HZ", 50)
        assert main(["flash", "--port", emu.url, "--model", str(work / "v.bin")]) == 0
        capsys.readouterr()
        argv = ["verify", "--port", emu.url, "--model", work / "v.bin", "--data", work / "run.csv"]
        rc, text, err = _run(capsys, [*argv, "--output", "strain_0", "--json"])
    assert rc == 0, err
    result = json.loads(text)
    assert result["identical"]
    print(f"\nfit: float model {fit_float:.2f} %, board's estimates {result['fit']['strain_0']:.2f} %")
    assert abs(result["fit"]["strain_0"] - fit_float) <= 0.5
