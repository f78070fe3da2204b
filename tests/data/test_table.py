"""read_table: header groups, trailing commas, empty cells, and errors naming line/column."""

import math

import numpy as np
import pytest

from porosense.data import read_table
from porosense.errors import InputError


def write(tmp_path, text, name="t.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_plain_header_picks_columns_by_name(tmp_path):
    table = read_table(write(tmp_path, "u_N,y_m\n1.5,-2e-3\n3,4\n"))
    assert table.names == ["u_N", "y_m"]
    assert np.array_equal(table["y_m"], [-2e-3, 4.0])
    assert len(table) == 2


def test_grouped_header_with_trailing_commas(tmp_path):
    text = '"r",,"u",,"fs",\n1,2,3,4,78125,\n5,6,7,8,,\n\n'
    table = read_table(write(tmp_path, text))
    assert table.names == ["r_0", "r_1", "u_0", "u_1", "fs"]
    assert table["u"].shape == (2, 2)
    assert np.array_equal(table["u"][:, 1], [4.0, 8.0])
    assert table["fs"][0] == 78125 and math.isnan(table["fs"][1])


def test_rows_with_extra_trailing_comma_under_plain_header(tmp_path):
    table = read_table(write(tmp_path, "a,b\n1,2,\n3,4,\n"))
    assert np.array_equal(table["b"], [2.0, 4.0])


@pytest.mark.parametrize(
    "text, line, column",
    [
        ("a,b\n1,2\n3,x\n", 3, 2),
        ("a,b,c\n1,2,3\n4,5,6\n7,8,1.2.3\n", 4, 3),
        ('"r",,"y",\n1,2,3,\n4,nan?,6,\n', 3, 2),
    ],
)
def test_non_number_names_file_line_column(tmp_path, text, line, column):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as err:
        read_table(path)
    message = str(err.value)
    assert str(path) in message and f"line {line}" in message and f"column {column}" in message


def test_wrong_cell_count_names_line(tmp_path):
    path = write(tmp_path, "a,b\n1,2\n3,4,5,6\n")
    with pytest.raises(InputError, match=r"line 3.*expected 2 cells, found 4"):
        read_table(path)


@pytest.mark.parametrize("text, pattern", [("", "empty file"), (",,\n1,2\n", "line 1"), ("a,a\n1,2\n", "duplicate")])
def test_bad_header(tmp_path, text, pattern):
    with pytest.raises(InputError, match=pattern):
        read_table(write(tmp_path, text))


def test_missing_file_and_missing_column(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_table(tmp_path / "absent.csv")
    table = read_table(write(tmp_path, "a\n1\n"))
    with pytest.raises(InputError, match="no column named 'b'"):
        table["b"]


def test_measured_benchmark_files(shared_data):
    est = read_table(shared_data / "wh_process_noise" / "WH_EstimationExample.csv")
    assert est["u"].shape == (8192, 10) and est["y"].shape == (8192, 10)
    assert est["fs"][0] == 78125 and np.isnan(est["fs"][1:]).all()
    assert np.isfinite(est["y"]).all()
    bw = read_table(shared_data / "boucwen" / "test_multisine.csv")
    assert bw.names == ["u_N", "y_m"] and len(bw) == 8192
