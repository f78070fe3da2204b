"""porosense quantize / flash / verify end to end on the emulator."""

import json

import pytest

from porosense.cli import main
from porosense.protocol.model_blob import MAX_BLOB_LEN
from porosense.quant import ModelBlob


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    from porosense import ident
    from porosense.sim import run_experiment

    d = tmp_path_factory.mktemp("quant-cli")
    recs = [run_experiment("contractor", e, rate_hz=50, seed=i) for i, e in enumerate(["staircase", "step_20"])]
    m = ident.Linear(n_poles=2, n_zeros=1).fit(
        u=[recs[0]["dR_0"][:, None]], y=[recs[0]["strain_0"]], ts=0.02, inputs=["dR_0"], output="strain_0"
    )
    m.save(d / "model.json")
    recs[1].to_csv(d / "step_20.csv")
    return d


def test_quantize_writes_blob_report_and_header(model_file, capsys):
    d = model_file
    rc = main(
        [
            "quantize",
            str(d / "model.json"),
            "--out",
            str(d / "m.bin"),
            "--json-out",
            str(d / "r.json"),
            "--header",
            str(d / "m.h"),
            "--data",
            str(d / "step_20.csv"),
        ]
    )
    assert rc == 0
    blob = ModelBlob.from_bytes((d / "m.bin").read_bytes())
    rep = json.loads((d / "r.json").read_text())["report"]
    assert rep["blob_bytes"] == blob.length <= MAX_BLOB_LEN
    assert abs(rep["fits"][0]["loss_points"]) <= 0.5 and rep["saturated_samples"] == 0
    assert f"M_LEN {blob.length}" in (d / "m.h").read_text()
    assert "blob written" in capsys.readouterr().out


def test_quantize_refuses_a_missing_model(tmp_path, capsys):
    rc = main(["quantize", "--model", str(tmp_path / "none.json"), "--out", str(tmp_path / "x.bin")])
    err = capsys.readouterr().err
    assert rc == 4 and "not found" in err and "Traceback" not in err


def test_flash_and_verify_on_the_emulator(model_file, capsys):
    pytest.importorskip("porosense.emulator")
    from porosense.emulator import Emulator

    d = model_file
    if not (d / "m.bin").exists():
        main(["quantize", "--model", str(d / "model.json"), "--out", str(d / "m.bin")])
    with Emulator(actuator="contractor") as emu:
        assert main(["flash", "--port", emu.url, "--model", str(d / "m.bin")]) == 0
        assert (
            main(["verify", "--port", emu.url, "--model", str(d / "m.bin"), "--data", str(d / "step_20.csv"), "--json"])
            == 0
        )
    out = capsys.readouterr().out
    result = json.loads(out[out.index("{") :])
    assert result["identical"] and result["mismatched_values"] == 0 and result["samples"] > 1000
