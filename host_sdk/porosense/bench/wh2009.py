"""The 2009 Wiener-Hammerstein benchmark (Schoukens, Suykens, Ljung 2009), run on a user's copy.

The benchmark file is public (nonlinearbenchmark.org, ``WienerHammerBenchmark.csv``: columns
uBenchMark, yBenchMark and fs, 188,000 samples at 51.2 kHz) but not shipped with porosense; give
its path to ``porosense bench ident --wh2009 PATH``. The official split: estimation samples
5,200..105,199, test samples 105,200..183,999, of which the first 50 initialise the model's
state and are not scored; the figure is the test RMSE in mV. The model is simulated from rest
over the whole test segment (its first 50 samples are its warm-up), identified by the default
search of ``porosense identify --structure wh`` on the estimation samples (the last 25 % of
them validate).
"""

from __future__ import annotations

import resource
import time
from pathlib import Path

import numpy as np

from porosense.errors import InputError

ESTIMATION = slice(5_200, 105_200)  # samples 5,200..105,199
TEST = slice(105_200, 184_000)  # samples 105,200..183,999
STATE_SAMPLES = 50  # the first test samples, for the model's state: not scored
# Published test RMSE (mV) on this split (as collected in the benchmark's literature).
PUBLISHED_MV = {
    "best linear approximation": 43.4,
    "polynomial NARX": 27.3,
    "LSTM": 4.45,
    "NL-LFR": 0.294,
    "best block-structured": 0.28,
    "best known (neural state space)": 0.241,
}
COLUMNS = ("uBenchMark", "yBenchMark", "fs")


def load(path) -> tuple[np.ndarray, np.ndarray, float]:
    """(u, y, fs) of the benchmark file: inputs and outputs in V, fs in Hz (its first value)."""
    from porosense.data import read_table

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file (the WH2009 benchmark file WienerHammerBenchmark.csv)")
    table = read_table(path)
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise InputError(f"{path}: no column {', '.join(missing)} (expected {', '.join(COLUMNS)})")
    u, y = np.asarray(table.columns["uBenchMark"], float), np.asarray(table.columns["yBenchMark"], float)
    fs_col = np.asarray(table.columns["fs"], float)
    fs = fs_col[np.isfinite(fs_col)]
    if len(u) < TEST.stop:
        raise InputError(f"{path}: {len(u)} samples, the official split needs {TEST.stop}")
    if not len(fs) or not fs[0] > 0:
        raise InputError(f"{path}: no sample rate in column fs")
    return u, y, float(fs[0])


def split(u, y):
    """((u_est, y_est), (u_test, y_test)) of the official split."""
    return (u[ESTIMATION], y[ESTIMATION]), (u[TEST], y[TEST])


def test_rmse_mv(model, u_test, y_test) -> float:
    """Test RMSE in mV: the model simulated from rest over the test segment, scored past its
    first STATE_SAMPLES samples."""
    yhat = np.ravel(model.predict(u=np.asarray(u_test, float)[:, None]))
    e = np.asarray(y_test, float)[STATE_SAMPLES:] - yhat[STATE_SAMPLES:]
    return float(1e3 * np.sqrt(np.mean(e**2)))


def _cpu() -> float:
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def run(path, structure: str = "wh", executor=None) -> dict:
    """Identify on the estimation samples with the default search of ``structure``; test RMSE,
    wall and CPU time, and the published figures beside it."""
    from porosense import ident

    u, y, fs = load(path)
    (ue, ye), (ut, yt) = split(u, y)
    t0, c0 = time.perf_counter(), _cpu()
    found = ident.identify(
        u=[ue[:, None]],
        y=[ye],
        ts=1.0 / fs,
        structures=(structure,),
        inputs=("u",),
        outputs=("y",),
        executor=executor,
        progress=False,
    )
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    best = found.results[0].best
    rmse = test_rmse_mv(found.model, ut, yt)
    return {
        "file": str(path),
        "fs_hz": fs,
        "estimation_samples": len(ye),
        "test_samples_scored": len(yt) - STATE_SAMPLES,
        "structure": structure,
        "selected": f"{best.structure} {best.n_poles}p{best.n_zeros}z",
        "test_rmse_mV": rmse,
        "wall_s": wall,
        "cpu_s": cpu,
        "published_mV": dict(PUBLISHED_MV),
        "ratio_to_published": {k: rmse / v for k, v in PUBLISHED_MV.items()},
    }


def summary(r: dict) -> list[str]:
    """One line for the result and one for the published table."""
    published = ", ".join(f"{k} {v:g}" for k, v in r["published_mV"].items())
    return [
        f"WH2009 benchmark (official split, {r['estimation_samples']:,} estimation / {r['test_samples_scored']:,} "
        f"test samples): identify --structure {r['structure']} selected {r['selected']}, test RMSE "
        f"{r['test_rmse_mV']:.3f} mV in {r['wall_s']:.0f} s wall, {r['cpu_s']:.0f} s CPU (goal <= 0.3 mV, <= 5 min "
        f"on 2 cores)",
        f"WH2009 published test RMSE (mV): {published}; ours / best block-structured "
        f"{r['ratio_to_published']['best block-structured']:.2f}",
    ]
