"""No recording lost: `porosense control run --out` writes the run sample by sample while it goes
on (porosense.data.SampleLog, flushed every second), so a SIGKILL leaves every sample up to then
readable; a run that ends replaces the log by its whole recording in one rename; an existing
--out (control run, predict, quantize) is replaced only with --force."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from porosense.control.gainsfile import FORMAT, VERSION
from porosense.data.sample_log import SampleLog

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "device"))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from models import make_blob

    d = tmp_path_factory.mktemp("nolost")
    (d / "m.bin").write_bytes(make_blob(1))
    doc = {"format": FORMAT, "version": VERSION, "gains": {"kp_kpa": 2.0, "ki_kpa_per_s": 1.0, "slew_per_s": 50.0}}
    (d / "g.json").write_text(json.dumps(doc))
    return d


def _run_args(d: Path, out: Path, hold: float) -> list[str]:
    return [
        *("control", "run", "--port", "emulator", "--model", str(d / "m.bin"), "--gains", str(d / "g.json")),
        *("--target", "0.5", "--hold", str(hold), "--out", str(out)),
    ]


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_sigkill_leaves_the_samples_recorded_so_far(files, tmp_path):
    out = tmp_path / "run.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "porosense", *_run_args(files, out, 600.0)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and (not out.exists() or len(_rows(out)) < 50):
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            time.sleep(0.2)
        assert out.exists(), "no samples on disk while the run goes on"
        time.sleep(2.0)
        seen = len(_rows(out))  # on disk more than a flush period before the kill
        time.sleep(1.2)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    rows = _rows(out)
    t = [int(r["t_dev_us"]) for r in rows]
    print(f"SIGKILL during control run: {len(rows)} samples readable ({(t[-1] - t[0]) / 1e6:.1f} s of device time)")
    assert len(rows) >= seen > 50
    assert all(b > a for a, b in zip(t, t[1:]))  # whole rows, in order
    assert set(rows[0]) == {"t_dev_us", "estimate_0", "target_lsb_0", "cmd_kpa_0", "dR_0", "status"}


def test_finished_run_replaces_its_log_and_out_is_not_overwritten(files, tmp_path, capsys):
    from porosense.cli import main

    out = tmp_path / "run.csv"
    assert main(_run_args(files, out, 2.0)) == 0
    rows = _rows(out)
    assert "target_0" in rows[0] and out.with_suffix(".json").exists()
    assert not list(tmp_path.glob("*.whole*"))
    capsys.readouterr()
    before = out.read_bytes()
    assert main(_run_args(files, out, 2.0)) == 2
    err = capsys.readouterr().err.strip()
    assert "exists" in err and "--force" in err and len(err.splitlines()) == 1
    assert out.read_bytes() == before


def test_sample_log_flushes_within_its_period(tmp_path):
    path = tmp_path / "log.csv"
    with SampleLog(path, ["a", "b"], flush_s=0.05) as log:
        log.append((1, 2.5))
        time.sleep(0.06)
        log.append((2, float("nan")))  # flushed: the period passed
        assert path.read_text() == "a,b\n1,2.5\n2,\n"
