"""No recording lost by `porosense simulate`, and no recording or model replaced unasked:
simulate writes each recording whole (a hidden temporary file renamed onto it) as soon as it is
simulated, so a SIGKILL in the middle of a run leaves every recording finished before it readable
and identical to the same recording simulated again, and none half-written under its name;
simulate (also --replay), identify and predict refuse to replace an existing recording, model or
prediction unless --force, before they compute anything. (record and control run --out: tests/record/
test_record_cli.py and tests/strain_control/test_no_recording_lost.py.)"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import Recording
from porosense.errors import InputError
from porosense.sim import run_experiment

RATE_HZ = 50


def _recordings(folder: Path) -> list[Path]:
    """The CSV recordings under their own names (not the hidden temporary files)."""
    return sorted(p for p in folder.glob("*.csv") if not p.name.startswith("."))


def test_sigkill_keeps_every_recording_simulated_before_it(tmp_path):
    out = tmp_path / "sim"
    # 400 recordings of step_10 (65 s at 50 Hz each): several seconds of work, killed halfway.
    argv = [sys.executable, "-m", "porosense", "simulate", "contractor", "-e", "step_10", "--repeats", "400"]
    argv += ["--rate", str(RATE_HZ), "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and (not out.is_dir() or len(_recordings(out)) < 20):
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            time.sleep(0.05)
        seen = set(_recordings(out))
        assert len(seen) >= 20, "no recordings on disk while the run goes on"
        time.sleep(0.3)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    kept = _recordings(out)
    assert proc.returncode == -signal.SIGKILL and len(kept) < 400, "the run ended before the kill"
    assert seen <= set(kept)
    n = None
    for path in kept:
        rec = Recording.from_csv(path)
        n = n or len(rec)
        assert len(rec) == n and np.all(np.diff(rec.t) > 0), path
    # Whole and right: the first and the last kept recording equal the same ones simulated again.
    seeds = sorted(int(p.stem.rsplit("_s", 1)[1]) for p in kept)
    for seed in (seeds[0], seeds[-1]):
        again = run_experiment("contractor", "step_10", rate_hz=RATE_HZ, seed=seed)
        rec = Recording.from_csv(out / f"contractor_step_10_p82_l0_s{seed}.csv")
        assert np.array_equal(rec["dR_0"], again["dR_0"]) and np.array_equal(rec.t, again.t)
    print(
        f"SIGKILL during simulate: {len(kept)} of 400 recordings kept, each whole ({n} samples); "
        f"{len(seen)} on disk 0.3 s before the kill; seeds {seeds[0]}..{seeds[-1]} without a gap: "
        f"{seeds == list(range(seeds[0], seeds[-1] + 1))}"
    )
    assert seeds == list(range(len(seeds)))  # in order, none missing below the last


def _one_line(capsys, words: str) -> None:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and "--force" in err, err


@pytest.mark.parametrize("fmt", ["csv", "mat"])
def test_simulate_refuses_to_replace_a_recording_unless_forced(tmp_path, capsys, fmt):
    args = ["simulate", "contractor", "-e", "step_10", "-e", "step_20", "--rate", "10", "--out", str(tmp_path)]
    args += ["--format", fmt]
    # The second recording is already there: nothing is simulated, nothing written.
    old = tmp_path / f"contractor_step_20_p82_l0_s0.{fmt}"
    old.write_bytes(b"kept")
    assert main(args) == 2
    _one_line(capsys, f"{old} exists")
    assert old.read_bytes() == b"kept" and sorted(p.name for p in tmp_path.iterdir()) == [old.name]
    assert main([*args, "--force"]) == 0
    assert old.read_bytes() != b"kept" and len(list(tmp_path.glob(f"*.{fmt}"))) == 2
    capsys.readouterr()
    if fmt == "csv":  # a CSV's JSON sidecar is part of the recording
        for p in [*tmp_path.glob("contractor_step_10_*"), old]:
            p.unlink()
        assert main(args) == 2
        _one_line(capsys, f"{old.with_suffix('.json')} exists: --force")


def test_replay_identify_and_predict_refuse_to_replace_their_output_unless_forced(tmp_path, capsys):
    rec = run_experiment("contractor", "step_20", rate_hz=10, seed=0)
    rec.to_csv(tmp_path / "rec.csv")
    out = tmp_path / "rec_sim.csv"
    out.write_text("kept\n")
    assert main(["simulate", "contractor", "--replay", str(tmp_path / "rec.csv"), "--out", str(out)]) == 2
    _one_line(capsys, f"{out} exists")
    assert out.read_text() == "kept\n"
    model = tmp_path / "model.json"
    model.write_text("kept\n")
    args = ["identify", "--data", str(tmp_path / "rec.csv"), "--input", "dR_0", "--output", "strain_0"]
    args += ["--structure", "linear", "--poles", "1", "--zeros", "0", "--quiet", "--out", str(model)]
    assert main(args) == 2
    _one_line(capsys, f"{model} exists")
    assert model.read_text() == "kept\n"
    assert main([*args, "--force"]) == 0
    assert '"models"' in model.read_text()
    pred = tmp_path / "pred.csv"
    pred.write_text("kept\n")
    args = ["predict", "--model", str(model), "--data", str(tmp_path / "rec.csv"), "--out", str(pred)]
    assert main(args) == 2
    _one_line(capsys, f"{pred} exists")
    assert pred.read_text() == "kept\n"
    assert main([*args, "--force"]) == 0 and pred.read_text().startswith("t,")


@pytest.mark.parametrize(
    ("argv", "existing"),
    [
        (["calibrate", "contractor", "--data", "{d}/rec.csv", "--out", "{d}/params.json"], "params.json"),
        (["control", "tune", "--data", "{d}/rec.csv", "--out", "{d}/gains.json"], "gains.json"),
        (
            ["diagnose", "--data", "{d}/rec.csv", "--input", "dR_0", "--output", "strain_0", "--model", "{d}/m.json"]
            + ["--save-extended", "{d}/ext.json"],
            "ext.json",
        ),
        (["record", "--calibrate", "{d}/a.png", "--square-mm", "20", "--out", "{d}/camera.json"], "camera.json"),
        (["export", "--model", "{d}/m.json", "--c", "--mat"], "m.mat"),  # m.c is not written either
    ],
)
def test_every_command_that_writes_a_model_or_parameters_refuses_to_replace_them(tmp_path, capsys, argv, existing):
    """Before it reads anything: exit 2, one line naming the file, nothing written or changed."""
    (tmp_path / existing).write_text("kept\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main([a.format(d=tmp_path) for a in argv]) == 2
    _one_line(capsys, f"{tmp_path / existing} exists")
    assert (tmp_path / existing).read_text() == "kept\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_recording_never_replaces_a_model_or_parameter_file_of_its_stem(tmp_path):
    """Recording.to_csv (every command's recording: record, control run, simulate, demo) writes its
    units to NAME.json: a JSON there that is not a recording's sidecar (a model, a parameter file)
    is refused whole, before the CSV is written; its own sidecar is replaced as before."""
    rec = Recording(np.arange(5) / 10.0, {"dR_0": np.linspace(0.0, -4.0, 5)}, {}, {"dR_0": "%"})
    model = tmp_path / "run.json"
    model.write_text('{"kind": "wiener_hammerstein", "ts": 0.02}')
    before = model.read_bytes()
    with pytest.raises(InputError, match="not a recording's sidecar"):
        rec.to_csv(tmp_path / "run.csv")
    assert model.read_bytes() == before and not (tmp_path / "run.csv").exists()
    rec.to_csv(tmp_path / "other.csv")
    rec.to_csv(tmp_path / "other.csv")  # its own sidecar: replaced, the recording reads back
    assert np.array_equal(Recording.from_csv(tmp_path / "other.csv")["dR_0"], rec["dR_0"])
