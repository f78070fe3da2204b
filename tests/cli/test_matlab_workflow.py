"""A MATLAB user's files and a European spreadsheet's CSV identify without edits.

The data come from an independent generator (a random stable second-order system, seeded),
written the way MATLAB writes .mat files (v5 and v7.3; named vectors with Ts, or a struct) and
the way a spreadsheet in a European locale writes CSV (semicolons, decimal commas). Every
format must give the same model as a plain comma-separated file with the same numbers.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from data.matlab_files import write_european_csv, write_mat_v5, write_mat_v73

from porosense import ident
from porosense.cli import main

SEED = 2026


@pytest.fixture(scope="module")
def recording():
    from scipy import signal

    rng = np.random.default_rng(SEED)
    ts = float(rng.choice([0.01, 0.02, 0.05]))
    r, w = rng.uniform(0.7, 0.95), rng.uniform(0.05, 0.5)
    a = [1, -2 * r * np.cos(w), r * r]
    b = [rng.uniform(0.2, 1.0), rng.uniform(-0.5, 0.5)]
    n = 1500
    u = np.repeat(rng.uniform(-1, 1, n // 25), 25) * rng.uniform(1, 100)
    y0 = signal.lfilter(b, a, u)
    noise_sd = 0.03 * np.std(y0)
    y = y0 + rng.normal(0, noise_sd, n)
    # Best achievable fit with this noise: 100 (1 - sd(noise) / sd(y)).
    return {"ts": ts, "t": np.arange(n) * ts, "u": u, "y": y, "ideal_fit": 100 * (1 - noise_sd / np.std(y))}


def _identify(path, tmp_path, name):
    out = tmp_path / f"{name}.json"
    rc = main(
        [
            "identify",
            "--data",
            str(path),
            "--input",
            "u",
            "--output",
            "y",
            "--structure",
            "linear",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--quiet",
            "--out",
            str(out),
            "--json-out",
            str(tmp_path / "r.json"),
        ]
    )
    assert rc == 0
    report = json.loads((tmp_path / "r.json").read_text())
    return ident.load_model(out), report


@pytest.mark.parametrize(
    "fmt", ["mat_v5_vectors", "mat_v5_struct", "mat_v73_vectors", "mat_v73_struct", "european_csv"]
)
def test_matlab_and_european_files_identify_without_edits(recording, tmp_path, fmt):
    rec = recording
    ref_csv = tmp_path / "ref.csv"
    ref_csv.write_text(
        "t,u,y\n"
        + "\n".join(f"{t!r},{u!r},{y!r}" for t, u, y in zip(rec["t"].tolist(), rec["u"].tolist(), rec["y"].tolist()))
        + "\n"
    )
    ref, ref_report = _identify(ref_csv, tmp_path, "ref")

    if fmt == "european_csv":
        path = tmp_path / "messung.csv"
        write_european_csv(path, {"t": rec["t"], "u": rec["u"], "y": rec["y"]}, fmt="{:.9g}")
    else:
        path = tmp_path / f"{fmt}.mat"
        writer = write_mat_v5 if fmt.startswith("mat_v5") else write_mat_v73
        writer(
            path,
            {"u": rec["u"], "y": rec["y"], "Ts": np.array([[rec["ts"]]])},
            struct_name="data" if fmt.endswith("struct") else None,
        )
    model, report = _identify(path, tmp_path, fmt)
    assert report["ts"] == pytest.approx(rec["ts"], rel=1e-9)  # Ts from the file, no --ts given
    yhat, yref = model.predict(u=rec["u"][:, None]), ref.predict(u=rec["u"][:, None])
    diff = float(np.max(np.abs(yhat - yref)) / np.max(np.abs(yref)))
    fit = ident.fit_percent(rec["y"], yhat)
    print(
        f"{fmt}: fit {fit:.2f} % (best possible {rec['ideal_fit']:.2f} %), max difference from the CSV "
        f"model {diff:.1e} of max |y|"
    )
    # .mat holds the same doubles: the same model. The European CSV rounds to 9 digits.
    assert diff <= (1e-9 if fmt.startswith("mat") else 1e-4)
    assert fit >= rec["ideal_fit"] - 3.0  # a correct 2-pole model reaches the noise floor
