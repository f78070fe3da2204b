"""``porosense control``: tune end to end on simulated recordings; every user mistake is one
line with the documented exit code (docs/cli.md: 2 bad input, 3 device problem), no traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from porosense.cli import main


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    from porosense.sim import run_experiment

    d = tmp_path_factory.mktemp("ctl")
    for i, e in enumerate(("step_10", "step_20", "step_40", "step_60")):
        run_experiment("contractor", e, rate_hz=50, seed=i).to_csv(d / f"{e}.csv")
    (d / "nocmd.csv").write_text("t,strain_0\n0,0\n0.02,1\n0.04,2\n")
    (d / "flat.csv").write_text("t,p_cmd_0,strain_0\n" + "\n".join(f"{k * 0.02},0,0" for k in range(50)) + "\n")
    (d / "traj_bad.csv").write_text("t_s,target\n0,5\n2,10\n1,12\n")
    (d / "traj_nocol.csv").write_text("t_s,goal\n0,5\n2,10\n")
    return d


def test_tune_writes_gains_and_a_predicted_step(work, capsys):
    rc = main(
        [
            "control",
            "tune",
            *(str(work / f"step_{v}.csv") for v in (10, 20, 40, 60)),
            "--out",
            str(work / "gains.json"),
            "--tau-cl",
            "0.5",
            "--plot",
            str(work / "step.png"),
            "--json",
        ]
    )
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    g = doc["gains"]
    p = doc["plant"]
    # the rule stated in the file, applied to the plant in the file
    kp = p["T"] / (p["K"] * (0.5 + p["theta"] + p["ts"] / 2))
    assert g["kp_kpa"] == pytest.approx(kp, rel=1e-9) and g["ki_kpa_per_s"] == pytest.approx(kp / p["T"], rel=1e-9)
    assert "lambda" in doc["rule"] and doc["tau_cl_s"] == 0.5
    assert 0.3 < p["K"] < 0.6  # % strain per kPa: 26 % over 60 kPa, steeper mid-stroke
    assert doc["predicted"]["overshoot_pct"] < 5 and 0 < doc["predicted"]["settling_s"] < 5
    assert json.loads((work / "gains.json").read_text())["gains"] == g
    assert (work / "step.png").stat().st_size > 10_000


CASES = [
    ("control tune --data {d}/nocmd.csv", 2, "p_cmd_0"),
    ("control tune --data {d}/step_10.csv --output strain_9", 2, "strain_9"),
    ("control tune --data {d}/step_10.csv --tau-cl 0", 2, "--tau-cl"),
    ("control tune --data {d}/step_10.csv --tau-cl -2", 2, "--tau-cl"),
    ("control tune --data {d}/step_10.csv --slew nan", 2, "--slew"),
    ("control tune --data {d}/flat.csv", 2, "never changes"),
    ("control tune --data {d}/absent.csv", 2, "not found"),
    ("control tune --data {d}/step_10.csv --out {d}/nodir/g.json", 2, "does not exist"),
    ("control run --port emulator --target 10 --trajectory {d}/traj_bad.csv", 2, "either"),
    ("control run --port emulator --trajectory {d}/traj_bad.csv", 2, "increase"),
    ("control run --port emulator --trajectory {d}/traj_nocol.csv", 2, "target"),
    ("control run --port emulator --target 10 --hold 0", 2, "--hold"),
    ("control run --port emulator --target 10 --gains {d}/step_10.csv", 2, "gains file"),
    ("control run --port emulator:octopus --target 10", 2, "octopus"),
    ("control run --port socket://127.0.0.1:1 --target 10", 3, "127.0.0.1:1"),
    ("control", 2, "subcommand"),
]


@pytest.mark.parametrize("args,code,words", CASES, ids=[f"{i}:{c[0][:40]}" for i, c in enumerate(CASES)])
def test_mistake_is_one_line_with_its_exit_code(work, args, code, words, capsys):
    rc = main([a.replace("{d}", str(work)) for a in args.split()])
    err = capsys.readouterr().err.strip()
    assert rc == code, err
    assert len(err.splitlines()) == 1, err
    assert words in err, err


def test_missing_port_is_a_usage_error_without_traceback():
    proc = subprocess.run(
        [sys.executable, "-m", "porosense", "control", "run", "--target", "10"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and "--port" in proc.stderr.splitlines()[-1] and "Traceback" not in proc.stderr


def test_trajectory_file_forms(tmp_path):
    from porosense.cli.control import read_trajectory

    (tmp_path / "a.csv").write_text("t_s,target\n0,0\n1,5\n3,5\n")
    (tmp_path / "b.csv").write_text("t_s,target0,target1,target2\n0,0,1,2\n2,5,6,7\n")
    t, y = read_trajectory(tmp_path / "a.csv")
    assert np.array_equal(t, [0, 1, 3]) and np.array_equal(y, [0, 5, 5])
    t, y = read_trajectory(tmp_path / "b.csv")
    assert y.shape == (2, 3) and y[1, 2] == 7
