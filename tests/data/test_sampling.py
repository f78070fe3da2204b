"""The time base of every file a command reads (porosense.data.check_sampling, docs/cli.md).

Each case is a file as a user would bring it: time in ms under a plain name, a units row,
dropped, repeated or reordered samples, host-clock jitter, MATLAB files with the time unit
stated, and the smaller reading mistakes (header only, quoted decimal commas, comments,
binary files, unequal MATLAB vectors).
"""

from __future__ import annotations

import numpy as np
import pytest

from porosense.data import check_sampling, load_data
from porosense.data.sampling import GAP_FACTOR, PLAUSIBLE_RATE_HZ
from porosense.errors import InputError
from tests.data.matlab_files import write_mat_v5, write_mat_v73


def _csv(path, t, header="t,u,y", units_row=None):
    u = np.sin(np.arange(len(t)) / 7.0)
    lines = [header] + ([units_row] if units_row else [])
    lines += [f"{a!r},{b!r},{2 * b!r}" for a, b in zip(np.asarray(t, float).tolist(), u.tolist())]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    "step,unit,ts",
    [(0.02, "s", 0.02), (20.0, "ms", 0.02), (10.0, "ms", 0.01), (0.1, "s", 0.1), (4.0, "ms", 0.004)],
)
def test_a_plain_time_column_is_read_in_the_unit_of_a_plausible_rate(tmp_path, step, unit, ts):
    table = load_data(_csv(tmp_path / "r.csv", np.arange(200) * step))
    assert table.sampling.time_unit == unit and table.ts == pytest.approx(ts, rel=1e-12)
    assert "inferred" in table.sampling.describe() and f"in {unit}" in table.sampling.describe()
    assert table.time == pytest.approx(np.arange(200) * ts)


@pytest.mark.parametrize("step", [0.5, 0.75, 1.0])
def test_steps_where_both_units_are_plausible_are_refused_until_the_unit_is_given(tmp_path, step):
    lo, hi = PLAUSIBLE_RATE_HZ
    assert lo <= 1 / step <= hi and lo <= 1000 / step <= hi  # the band's overlap: both readings plausible
    path = _csv(tmp_path / "r.csv", np.arange(100) * step)
    with pytest.raises(InputError, match="ambiguous.*--time-unit"):
        load_data(path)
    assert load_data(path, time_unit="ms").ts == pytest.approx(step / 1000)
    assert load_data(path, time_unit="s").ts == pytest.approx(step)


@pytest.mark.parametrize(
    "header,units_row,ts,source",
    [
        ("t_ms,u,y", None, 0.02, "from its name"),
        ("time_s,u,y", None, 20.0, "from its name"),  # a 0.05 Hz logger, stated: taken as written
        ("t,u,y", "ms,V,%", 0.02, "units row"),
        ("t,u,y", "[s],[V],[%]", 20.0, "units row"),
    ],
)
def test_a_stated_unit_wins_over_inference(tmp_path, header, units_row, ts, source):
    table = load_data(_csv(tmp_path / "r.csv", np.arange(100) * 20.0, header=header, units_row=units_row))
    assert table.ts == pytest.approx(ts) and source in table.sampling.unit_source
    if units_row:
        assert len(table) == 100 and table.units["u"] in ("V", "[V]")


def test_the_sidecar_states_the_unit(tmp_path):
    import json

    path = _csv(tmp_path / "r.csv", np.arange(100) * 1.0)  # ambiguous alone
    (tmp_path / "r.json").write_text(json.dumps({"units": {"t": "ms"}}))
    table = load_data(path)
    assert table.ts == pytest.approx(1e-3) and "sidecar" in table.sampling.unit_source


@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73])
def test_a_mat_time_vector_in_ms_is_not_read_as_seconds(tmp_path, writer):
    t = np.arange(300) * 20.0
    writer(tmp_path / "r.mat", {"t": t, "u": np.sin(t / 100), "y": np.cos(t / 100)})
    table = load_data(tmp_path / "r.mat")
    assert table.ts == pytest.approx(0.02) and table.sampling.time_unit == "ms"


def test_a_mat_units_struct_and_time_unit_are_read(tmp_path):
    from scipy.io import savemat

    t = np.arange(100) * 1.0
    savemat(tmp_path / "a.mat", {"t": t[:, None], "y": t[:, None], "units": {"t": "ms", "y": "mm"}})
    table = load_data(tmp_path / "a.mat")
    assert table.ts == pytest.approx(1e-3) and table.units["y"] == "mm"
    savemat(tmp_path / "b.mat", {"y": t[:, None], "Ts": 20.0, "TimeUnit": "milliseconds"})
    assert load_data(tmp_path / "b.mat").ts == pytest.approx(0.02)


def _lines_of(err: str) -> str:
    return err.split(":")[1].strip()


def test_a_dropped_sample_is_refused_naming_the_gap_and_its_line(tmp_path):
    t = np.arange(500) * 0.02
    t[300:] += 0.2  # 10 samples lost before the 301st data row (line 302 with the header)
    path = _csv(tmp_path / "r.csv", t)
    with pytest.raises(InputError) as err:
        load_data(path)
    text = str(err.value)
    assert "line 302" in text and "gap of 0.22 s" in text and "--resample" in text and "\n" not in text


def test_resample_fills_the_gap_and_says_so(tmp_path):
    t = np.arange(500) * 0.02
    t[300:] += 0.2
    table = load_data(_csv(tmp_path / "r.csv", t), resample=True)
    assert len(table) == 510 and table.ts == pytest.approx(0.02)
    assert np.allclose(np.diff(table.time), 0.02)
    assert "resampled 500 samples onto 510" in table.sampling.describe()
    assert "largest gap filled 220 ms" in table.sampling.describe()
    assert table.columns["y"] == pytest.approx(2 * table.columns["u"])  # columns move together


def test_repeated_stamps_are_refused_or_averaged(tmp_path):
    t = np.arange(100) * 0.02
    t = np.insert(t, 40, t[40])
    path = _csv(tmp_path / "r.csv", t)
    with pytest.raises(InputError, match="line 43.*repeats"):
        load_data(path)
    table = load_data(path, resample=True)
    assert len(table) == 100 and "1 repeated stamp averaged" in table.sampling.describe()


def test_out_of_order_samples_are_refused_even_with_resample(tmp_path):
    t = np.arange(100) * 0.02
    t[[50, 51]] = t[[51, 50]]
    path = _csv(tmp_path / "r.csv", t)
    for resample in (False, True):
        with pytest.raises(InputError, match="line 53.*goes back"):
            load_data(path, resample=resample)


def test_host_clock_jitter_is_accepted_and_reported(tmp_path):
    rng = np.random.default_rng(3)
    t = np.cumsum(0.02 * (1 + rng.uniform(-0.3, 0.3, 400)))  # every step within GAP_FACTOR of the median
    assert GAP_FACTOR > 1.3
    table = load_data(_csv(tmp_path / "r.csv", t))
    assert table.ts == pytest.approx(0.02, rel=0.05) and "jitter" in table.sampling.describe()


def test_header_only_is_told_it_has_no_rows(tmp_path):
    (tmp_path / "h.csv").write_text("t,u,y\n")
    with pytest.raises(InputError, match="no data rows.*columns: t, u, y"):
        load_data(tmp_path / "h.csv")


def test_quoted_decimal_commas_with_comma_separators(tmp_path):
    rows = "\n".join(f'"{k * 0.02:.2f}","{k / 2:.1f}","{k:.1f}"'.replace(".", ",") for k in range(50))
    (tmp_path / "q.csv").write_text("t,u,y\n" + rows + "\n")
    for decimal in (None, ","):
        table = load_data(tmp_path / "q.csv", decimal=decimal)
        assert table.ts == pytest.approx(0.02) and table.columns["u"][3] == pytest.approx(1.5)


def test_comments_and_skipped_rows(tmp_path):
    body = "\n".join(f"{k * 0.02!r},{k!r},{k!r}" for k in range(50))
    (tmp_path / "c.csv").write_text("# exported by a logger\n# rate 50 Hz\nt,u,y\n" + body + "\n# end\n")
    assert len(load_data(tmp_path / "c.csv")) == 50
    (tmp_path / "s.csv").write_text("Logger v2\nserial 1234\nt,u,y\n" + body + "\n")
    with pytest.raises(InputError):
        load_data(tmp_path / "s.csv")
    assert len(load_data(tmp_path / "s.csv", skip_rows=2)) == 50


def test_a_binary_file_is_named_as_such(tmp_path):
    (tmp_path / "model.bin").write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputError, match="binary file.*model blob"):
        load_data(tmp_path / "model.bin")


def test_unequal_mat_vectors_are_named(tmp_path):
    from porosense.cli._data import require_columns

    write_mat_v5(tmp_path / "r.mat", {"t": np.arange(100) * 0.02, "u": np.ones(100), "y": np.ones(99)})
    table = load_data(tmp_path / "r.mat")
    with pytest.raises(InputError, match="'y' has 99 samples where the other variables have 100"):
        require_columns(table, ["u", "y"])


def test_check_sampling_states_what_it_found(tmp_path):
    table = load_data(_csv(tmp_path / "r.csv", np.arange(100) * 0.02), check=False)
    assert table.sampling is None
    s = check_sampling(table, time_unit="s")
    assert s.to_dict()["ts"] == pytest.approx(0.02) and "--time-unit" in s.describe() and "50 Hz" in s.describe()
