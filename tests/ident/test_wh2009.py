"""The WH2009 benchmark's split and test RMSE (porosense.bench.wh2009), on a synthetic file of the
benchmark's format: the benchmark itself is not shipped (a user gives its path)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from porosense.bench import wh2009
from porosense.errors import InputError

N = 188_000
FS = 51_200.0
NOISE_V = 1e-3  # 1 mV of output noise


def _truth(u):
    """A Wiener-Hammerstein circuit of our own: 2 poles, a soft saturation, 1 pole."""
    x = lfilter([0.2, 0.1], [1.0, -1.1, 0.4], u)
    return lfilter([0.3], [1.0, -0.7], np.tanh(2.0 * x))


@pytest.fixture(scope="module")
def bench_file(tmp_path_factory):
    rng = np.random.default_rng(2009)
    u = lfilter([1.0], [1.0, -0.5], rng.standard_normal(N)) * 0.5
    y = _truth(u) + NOISE_V * rng.standard_normal(N)
    path = tmp_path_factory.mktemp("wh2009") / "WienerHammerBenchmark.csv"
    rows = "\n".join(f"{a!r},{b!r},{FS!r}" for a, b in zip(u.tolist(), y.tolist()))
    path.write_text("uBenchMark,yBenchMark,fs\n" + rows + "\n")
    return path, u, y


class _Truth:
    """The generator itself as a model: its test RMSE is the output noise."""

    def predict(self, *, u):
        return _truth(np.asarray(u)[:, 0])


def test_official_split_and_test_rmse(bench_file):
    path, u, y = bench_file
    lu, ly, fs = wh2009.load(path)
    assert fs == FS and np.array_equal(lu, u) and np.array_equal(ly, y)
    (ue, ye), (ut, yt) = wh2009.split(lu, ly)
    assert len(ue) == len(ye) == 100_000 and ue[0] == u[5_200] and ue[-1] == u[105_199]
    assert len(ut) == len(yt) == 78_800 and ut[0] == u[105_200] and ut[-1] == u[183_999]
    # The truth simulated from rest over the test segment: past its 50 state samples only the
    # noise remains. 78,750 scored samples: the RMS of the noise is known to 0.25 % (one
    # standard error, 1 / sqrt(2 N)); bound 2 %.
    rmse = wh2009.test_rmse_mv(_Truth(), ut, yt)
    assert rmse == pytest.approx(1e3 * NOISE_V, rel=0.02)
    # Scoring the state samples too would count the start-up from rest.
    full = 1e3 * np.sqrt(np.mean((yt - _truth(ut)) ** 2))
    assert full != rmse


def test_a_file_of_another_format_is_one_line(tmp_path):
    bad = tmp_path / "x.csv"
    bad.write_text("u,y\n1,2\n3,4\n")
    with pytest.raises(InputError, match="no column uBenchMark, yBenchMark, fs"):
        wh2009.load(bad)
    short = tmp_path / "short.csv"
    short.write_text("uBenchMark,yBenchMark,fs\n" + "\n".join("0.1,0.2,51200" for _ in range(1000)) + "\n")
    with pytest.raises(InputError, match="the official split needs 184000"):
        wh2009.load(short)
    with pytest.raises(InputError, match="no such file"):
        wh2009.load(tmp_path / "absent.csv")


def test_published_table_is_printed_beside_the_result():
    r = {
        "estimation_samples": 100_000,
        "test_samples_scored": 78_750,
        "structure": "wh",
        "selected": "wh 6p5z",
        "test_rmse_mV": 0.30,
        "wall_s": 100.0,
        "cpu_s": 180.0,
        "published_mV": dict(wh2009.PUBLISHED_MV),
        "ratio_to_published": {k: 0.30 / v for k, v in wh2009.PUBLISHED_MV.items()},
    }
    lines = wh2009.summary(r)
    assert "0.300 mV" in lines[0] and "NL-LFR 0.294" in lines[1] and "best known (neural state space) 0.241" in lines[1]
    assert wh2009.PUBLISHED_MV["best linear approximation"] == 43.4 and wh2009.PUBLISHED_MV["LSTM"] == 4.45
