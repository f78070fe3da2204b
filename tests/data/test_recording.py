"""Recording: exact CSV+JSON and .mat round trips, access, slicing and file errors."""

import json

import numpy as np
import pytest

from porosense.data import Recording
from porosense.errors import InputError


def sample_recording(n=500, seed=3):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    return Recording(
        t,
        {
            "p_cmd_0": np.where(t % 2 < 1, -20.0, 0.0),
            "adc_0": rng.integers(-32768, 32767, n).astype(np.int16),
            "dR_0": rng.normal(-40, 20, n) * np.pi,  # full-precision floats
            "strain_0": np.concatenate([[np.nan], rng.random(n - 1) * 1e-300]),
            "valve_0": t % 2 < 1,
        },
        meta={
            "actuator": "contractor",
            "porosity": 82.0,
            "seed": np.int64(seed),
            "truth": ["strain_0"],
            "effects": {"drift": {"rate_pct_per_min": 0.5}},
        },
        units={"p_cmd_0": "kPa", "adc_0": "counts", "dR_0": "%", "strain_0": "%"},
    )


def assert_same(a: Recording, b: Recording):
    assert a.names == b.names
    assert np.array_equal(a.t, b.t)
    for name in a.names:
        assert a[name].dtype == b[name].dtype, name
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    assert a.meta == b.meta and a.units == b.units


def test_csv_json_round_trip_is_exact(tmp_path):
    rec = sample_recording()
    path = rec.to_csv(tmp_path / "rec.csv")
    assert path.with_suffix(".json").exists()
    assert_same(rec, Recording.from_csv(path))


def test_mat_round_trip_is_exact(tmp_path):
    from scipy.io import loadmat

    rec = sample_recording()
    path = rec.to_mat(tmp_path / "rec.mat")
    assert_same(rec, Recording.from_mat(path))
    raw = loadmat(path)  # what MATLAB sees: column vectors and a units struct
    assert raw["dR_0"].shape == (500, 1)
    assert str(raw["units"]["dR_0"][0, 0][0]) == "%"


def test_access_rate_and_slice():
    rec = sample_recording()
    assert rec.fs == pytest.approx(100.0)
    part = rec.slice(1.0, 2.0)
    assert len(part) == 100 and part.t[0] == pytest.approx(1.0)
    assert np.array_equal(part["dR_0"], rec["dR_0"][100:200])
    assert rec.matrix(["dR_0", "p_cmd_0"]).shape == (500, 2)
    with pytest.raises(InputError, match="no column 'nope'"):
        rec["nope"]


def test_length_mismatch_is_an_input_error():
    with pytest.raises(InputError, match="has 3 samples"):
        Recording(np.arange(4.0), {"x": np.zeros(3)})


def test_malformed_csv_and_sidecar(tmp_path):
    rec = sample_recording(20)
    path = rec.to_csv(tmp_path / "rec.csv")
    lines = path.read_text().splitlines()
    cells = lines[5].split(",")
    cells[3] = "abc"
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"rec\.csv: line 6, column 4 \('dR_0'\)"):
        Recording.from_csv(path)
    rec.to_csv(path)
    path.with_suffix(".json").write_text('{"meta": [1,}')
    with pytest.raises(InputError, match=r"rec\.json: line 1, column"):
        Recording.from_csv(path)


def test_csv_without_sidecar_needs_time(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("a,b\n1,2\n")
    with pytest.raises(InputError, match="no 't' column"):
        Recording.from_csv(p)
    p.write_text("t,dR_0,\n0,1,\n0.01,2,\n")
    rec = Recording.from_csv(p)
    assert rec.names == ["dR_0"] and rec.fs == pytest.approx(100.0)
    assert json.dumps(rec.meta) == "{}"
