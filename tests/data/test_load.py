"""load_data: MATLAB .mat (v5, v7.3), CSV dialects, and the sample period the data states."""

from __future__ import annotations

import numpy as np
import pytest

from porosense.data import load_data, resolve_ts
from porosense.errors import InputError

from .matlab_files import write_european_csv, write_mat_v5, write_mat_v73


def _signals(seed=5, n=400):
    rng = np.random.default_rng(seed)
    ts = rng.choice([0.01, 0.02, 0.05])
    return ts, {"t": np.arange(n) * ts, "u": rng.normal(size=n), "y": rng.normal(size=n) * 3}


@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73])
@pytest.mark.parametrize("struct", [None, "run"])
def test_mat_vectors_and_structs_read_as_columns(tmp_path, writer, struct):
    ts, sig = _signals()
    path = tmp_path / "run.mat"
    writer(path, {"u": sig["u"], "y": sig["y"], "Ts": np.array([[ts]])}, struct_name=struct)
    table = load_data(path)
    assert table.names == ["u", "y"]
    assert np.array_equal(table["u"], sig["u"]) and np.array_equal(table["y"], sig["y"])
    assert table.ts == pytest.approx(ts, rel=1e-12) and "Ts" in table.ts_source


@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73])
def test_mat_matrix_becomes_a_column_group_and_t_gives_ts(tmp_path, writer):
    ts, sig = _signals(seed=9)
    u = np.column_stack([sig["u"], 2 * sig["u"]])
    path = tmp_path / "m.mat"
    writer(path, {"t": sig["t"], "u": u, "y": sig["y"]})
    table = load_data(path)
    assert table.names == ["t", "u_0", "u_1", "y"]
    assert np.array_equal(table["u_1"], u[:, 1])
    assert table.ts == pytest.approx(ts, rel=1e-9)


def test_european_csv_reads_like_comma_csv(tmp_path):
    ts, sig = _signals(seed=11)
    path = tmp_path / "eu.csv"
    write_european_csv(path, sig)
    table = load_data(path)
    assert table.names == ["t", "u", "y"] and "semicolon" in table.dialect and "comma" in table.dialect
    assert np.max(np.abs(table["y"] - sig["y"])) <= 5e-7  # written with 6 decimals
    assert table.ts == pytest.approx(ts, rel=1e-6)


@pytest.mark.parametrize("sep", ["\t", " ", ","])
def test_separators_and_missing_header(tmp_path, sep):
    _, sig = _signals(seed=2, n=50)
    rows = [sep.join(repr(float(v)) for v in r) for r in zip(sig["u"], sig["y"])]
    path = tmp_path / "plain.txt"
    path.write_text("\n".join(rows) + "\n")
    table = load_data(path)
    assert table.names == ["col1", "col2"] and len(table) == 50
    assert np.array_equal(table["col2"], sig["y"])
    assert table.lines[0] == 1  # no header: the first data row is line 1


def test_empty_cell_is_reported_with_its_line(tmp_path):
    path = tmp_path / "gap.csv"
    path.write_text("t;u;y\n0;1,5;2\n0,1;;3\n0,2;1;4\n")
    table = load_data(path)
    with pytest.raises(InputError, match=r"line 3, column 'u': empty or NaN cell"):
        table.require_finite(["u", "y"])


def test_unreadable_dialect_names_what_was_seen(tmp_path):
    path = tmp_path / "odd.csv"
    path.write_text("t;u;y\n0;1;2\n1;2;3;4\n")
    with pytest.raises(
        InputError, match=r"line 3: expected 3 cells, found 4 \(read as semicolon-separated.*--separator"
    ):
        load_data(path)


def test_ts_from_data_and_disagreeing_ts(tmp_path):
    ts, sig = _signals(seed=3)
    path = tmp_path / "a.csv"
    write_european_csv(path, sig)
    table = load_data(path)
    assert resolve_ts([table], None) == pytest.approx(ts, rel=1e-6)
    assert resolve_ts([table], ts * 1.005) == pytest.approx(ts * 1.005)  # within 1 %
    with pytest.raises(InputError, match="disagrees with.*--ts-override"):
        resolve_ts([table], ts * 50)
    assert resolve_ts([table], ts * 50, override=True) == ts * 50
    for bad in (0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(InputError, match="positive finite"):
            resolve_ts([table], bad)
    bare = tmp_path / "bare.csv"
    bare.write_text("u,y\n1,2\n3,4\n")
    with pytest.raises(InputError, match="pass --ts"):
        resolve_ts([load_data(bare)], None)


def test_not_a_matlab_file(tmp_path):
    path = tmp_path / "broken.mat"
    path.write_bytes(b"\x00\x01garbage" * 20)
    with pytest.raises(InputError, match="broken.mat"):
        load_data(path)


@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73])
def test_recording_from_a_plain_matlab_file(tmp_path, writer):
    from porosense.data import Recording

    ts, sig = _signals(seed=21)
    path = tmp_path / "plain.mat"
    writer(path, {"u": sig["u"], "y": sig["y"]})
    with pytest.raises(InputError, match="no variable 't'.*Ts"):
        Recording.from_mat(path)
    rec = Recording.from_mat(path, ts=ts)
    assert rec.names == ["u", "y"] and rec.ts == pytest.approx(ts)
    assert np.array_equal(rec["y"], sig["y"])
