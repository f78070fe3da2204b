"""Units and sample rate travel with the model: a model fitted on dR/100 (the README's Python
example) and the same model on dR in % give the same blob and correct device estimates; an
undeclared dR/100 model is refused; flash and verify refuse a model whose rate is not the board's
(or set the board's rate with --set-rate)."""

import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.errors import ModelError
from porosense.ident import Linear, load_model
from porosense.quant import FixedPointEstimator, ModelBlob, fit_percent, quantize
from porosense.quant.quantize import device_inputs


@pytest.fixture(scope="module")
def recordings():
    from porosense.sim import run_experiment

    return [
        run_experiment("contractor", e, porosity=76, load_g=0, rate_hz=50, seed=s)
        for e, s in (("step_60", 2), ("step_20", 4))
    ]


def _integers(value, skip=("model_id", "crc")) -> list:
    """Every integer field of a decoded blob, in order (ids and checksums left out)."""
    import dataclasses

    if dataclasses.is_dataclass(value):
        return [x for f in dataclasses.fields(value) if f.name not in skip for x in _integers(getattr(value, f.name))]
    if isinstance(value, (tuple, list)):
        return [x for v in value for x in _integers(v)]
    if isinstance(value, (bool, int, np.integer)):
        return [int(value)]
    if isinstance(value, float):
        return [round(value * 1e6)]
    return []


def _fit(recs, scale, unit):
    est = recs[0]
    return Linear(n_poles=2, n_zeros=1, starts=1).fit(
        u=[est["dR_0"][:, None] * scale],
        y=[est["strain_0"]],
        ts=0.02,
        inputs=["dR_0"],
        output="strain_0",
        input_unit=unit,
        output_unit="%",
    )


def test_fraction_and_percent_models_give_the_same_blob_and_right_estimates(recordings, tmp_path):
    frac = _fit(recordings, 0.01, "dR/100")  # the README's Python example
    pct = _fit(recordings, 1.0, "%")  # what identify does on the CSV's dR columns
    frac.save(tmp_path / "frac.json")
    assert main(["quantize", "--model", str(tmp_path / "frac.json"), "--out", str(tmp_path / "frac.bin")]) == 0
    blob_cli = (tmp_path / "frac.bin").read_bytes()
    blob_api = quantize(frac.to_structure()).blob.to_bytes()
    blob_pct = quantize(pct.to_structure()).blob.to_bytes()
    assert blob_cli == blob_api
    # Fitted on dR in %, the same model (the fits see the same normalised data) gives the same blob,
    # up to one LSB where the scaling by 0.01 or by 1 rounds a 32-bit coefficient apart (measured
    # on the simulator's step_60 at seed 2: b0 -2121100263 against -2121100264; the CRC and the
    # model id follow the bytes).
    same = _integers(ModelBlob.from_bytes(blob_pct)), _integers(ModelBlob.from_bytes(blob_api))
    assert len(same[0]) == len(same[1]) and max(abs(x - y) for x, y in zip(*same)) <= 1
    # Device estimates equal the float model on the device's own inputs (not 100x).
    val = recordings[1]
    counts = device_inputs(val["dR_0"][:, None], 0.01)
    blob = ModelBlob.from_bytes(blob_api)
    full = np.zeros((len(counts), 3), dtype=np.int64)
    full[:, 0] = counts[:, 0]
    est, _ = FixedPointEstimator(blob).run(full)
    on_device = est[:, 0] * blob.out_scale[0]
    float_model = frac.predict(u=counts * 1e-4)
    ratio = np.dot(on_device, float_model) / np.dot(float_model, float_model)
    assert abs(ratio - 1.0) < 0.01, ratio
    assert fit_percent(float_model, on_device) >= 99.0
    # The file keeps name, unit and scale of every signal, and loads back with them.
    doc = json.loads((tmp_path / "frac.json").read_text())
    sig = doc["models"][0]["signals"]
    assert sig["inputs"] == [{"name": "dR_0", "unit": "dR/100", "scale": 0.01}]
    assert sig["output"] == {"name": "strain_0", "unit": "%", "scale": 1.0}
    again = load_model(tmp_path / "frac.json")
    assert again.input_units == ("dR/100",) and again.to_structure().input_lsb() == pytest.approx(1e-4)


def test_undeclared_fraction_model_is_refused_and_input_unit_fixes_it(recordings, tmp_path, capsys):
    undeclared = _fit(recordings, 0.01, None)
    with pytest.raises(ModelError, match="dR/100"):
        quantize(undeclared.to_structure())
    undeclared.save(tmp_path / "u.json")
    rc = main(["quantize", "--model", str(tmp_path / "u.json"), "--out", str(tmp_path / "u.bin")])
    err = capsys.readouterr().err
    assert rc == 4 and "dR/100" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "u.bin").exists()
    assert (
        main(
            [
                "quantize",
                "--model",
                str(tmp_path / "u.json"),
                "--out",
                str(tmp_path / "u.bin"),
                "--input-unit",
                "dR/100",
            ]
        )
        == 0
    )
    declared = _fit(recordings, 0.01, "dR/100")
    assert ModelBlob.from_bytes((tmp_path / "u.bin").read_bytes()).ts_us == 20_000
    assert (tmp_path / "u.bin").read_bytes() == quantize(declared.to_structure()).blob.to_bytes()


def test_model_files_without_units_still_load(recordings, tmp_path):
    m = _fit(recordings, 1.0, "%")
    m.save(tmp_path / "m.json")
    doc = json.loads((tmp_path / "m.json").read_text())
    for d in doc["models"]:
        del d["signals"]  # a file written before units were stored
    (tmp_path / "old.json").write_text(json.dumps(doc))
    old = load_model(tmp_path / "old.json")
    assert old.input_units == () and old.to_structure().input_lsb() == pytest.approx(0.01)


def test_flash_and_verify_check_the_rate(recordings, tmp_path, capsys):
    pytest.importorskip("porosense.emulator")
    from porosense.device import Device
    from porosense.emulator import Emulator

    m = Linear(n_poles=2, n_zeros=1, starts=1).fit(
        u=[recordings[0]["dR_0"][::2, None]],
        y=[recordings[0]["strain_0"][::2]],
        ts=0.04,
        inputs=["dR_0"],
        output="strain_0",
        input_unit="%",
    )  # 25 Hz
    m.save(tmp_path / "m25.json")
    assert main(["quantize", "--model", str(tmp_path / "m25.json"), "--out", str(tmp_path / "m25.bin")]) == 0
    recordings[1].to_csv(tmp_path / "val50.csv")
    capsys.readouterr()
    with Emulator(actuator="contractor") as emu:
        with Device.open(emu.url) as dev:
            board_hz = dev.sample_rate_hz()
        assert board_hz == 50
        rc = main(["flash", "--port", emu.url, "--model", str(tmp_path / "m25.bin")])
        err = capsys.readouterr().err
        assert rc == 4 and "25 Hz" in err and "50 Hz" in err and "--set-rate" in err
        with Device.open(emu.url) as dev:
            assert dev.model_info().crc != ModelBlob.from_bytes((tmp_path / "m25.bin").read_bytes()).crc
        assert main(["flash", "--port", emu.url, "--model", str(tmp_path / "m25.bin"), "--set-rate"]) == 0
        with Device.open(emu.url) as dev:
            assert dev.sample_rate_hz() == 25
        # verify refuses a recording at another rate than the model's
        rc = main(
            ["verify", "--port", emu.url, "--model", str(tmp_path / "m25.bin"), "--data", str(tmp_path / "val50.csv")]
        )
        err = capsys.readouterr().err
        assert rc == 2 and "20 ms" in err and "40 ms" in err
        # and a board whose rate was changed after flashing
        with Device.open(emu.url) as dev:
            dev.config_set("SAMPLE_RATE_HZ", 50)
        recordings[1].to_csv(tmp_path / "val.csv")
        half = _every_other(tmp_path / "val.csv", tmp_path / "val25.csv")
        rc = main(["verify", "--port", emu.url, "--model", str(tmp_path / "m25.bin"), "--data", str(half)])
        err = capsys.readouterr().err
        assert rc == 4 and "25 Hz" in err and "50 Hz" in err


def _every_other(src, dst):
    """The recording at half its rate (every other row), as a CSV."""
    lines = src.read_text().splitlines()
    dst.write_text("\n".join([lines[0]] + lines[1::2]) + "\n")
    return dst
