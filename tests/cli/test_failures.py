"""Every listed CLI failure: one line on stderr, the documented exit code, no traceback.

Exit codes (docs/cli.md): 0 ok, 1 no command, 2 bad input or usage, 3 device problem, 4 model problem.
The cases that used to succeed with wrong results (a disagreeing --ts, a NaN model or NaN data,
a replay of 0 samples, --max-poles beyond 20, a 33-bit model id, negative geometry, an unknown
inner model version) must now fail.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from porosense import ident
from porosense.cli import main


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """A 100 Hz recording (t, dR_0, strain_0), a fitted linear model, a NaN model and a version-99 model."""
    from scipy import signal

    d = tmp_path_factory.mktemp("fail")
    rng = np.random.default_rng(4)
    n = 800
    u = np.repeat(rng.uniform(-80, 0, n // 40), 40)
    y = signal.lfilter([0.05], [1, -0.8], -u / 4) + rng.normal(0, 0.02, n)
    t = np.arange(n) * 0.01
    rows = "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist()))
    (d / "run.csv").write_text("t,dR_0,strain_0\n" + rows + "\n")
    (d / "header_only.csv").write_text("t,dR_0,strain_0\n")
    nan_rows = rows.splitlines()
    nan_rows[7] = nan_rows[7].split(",")[0] + ",nan," + nan_rows[7].split(",")[2]
    (d / "nan.csv").write_text("t,dR_0,strain_0\n" + "\n".join(nan_rows) + "\n")
    m = ident.make_model("linear", n_poles=1, n_zeros=0).fit(
        u=u[:, None], y=y, ts=0.01, inputs=("dR_0",), output="strain_0"
    )
    m.save(d / "model.json")
    doc = json.loads((d / "model.json").read_text())
    doc["models"][0]["theta"][0] = float("nan")
    (d / "nan_model.json").write_text(json.dumps(doc))
    doc = json.loads((d / "model.json").read_text())
    doc["models"][0]["version"] = 99
    (d / "v99.json").write_text(json.dumps(doc))
    assert main(["quantize", "--model", str(d / "model.json"), "--out", str(d / "model.bin")]) == 0
    slow_rows = "\n".join(f"{2 * a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist()))
    (d / "run_50hz.csv").write_text("t,dR_0,strain_0\n" + slow_rows + "\n")  # the 100 Hz model's data at 50 Hz
    (d / "exists").write_text("a file\n")
    (d / "radii.csv").write_text("height_mm,radius_mm\n2.5,-0.7\n5,-1.7\n10,-3.7\n")
    return d


CASES = [
    # (arguments with {d} for the folder, exit code, words the message must hold)
    ("identify --data {d}/run.csv --input dR_0 --output strain_0 --ts inf --poles 1", 2, "positive finite"),
    ("identify --data {d}/run.csv --input dR_0 --output strain_0 --ts 0.5 --poles 1", 2, "disagrees"),
    ("identify --data {d}/run.csv --input dR_0 --output strain_0 --max-poles 100", 2, "--force"),
    ("identify --data {d}/nan.csv --input dR_0 --output strain_0 --poles 1", 2, "line 9"),
    ("predict --model {d}/model.json --data {d}/run.csv --out {d}/absent/p.csv", 2, "does not exist"),
    ("predict --model {d}/nan_model.json --data {d}/run.csv", 4, "non-finite"),
    ("predict --model {d}/v99.json --data {d}/run.csv", 4, "version 99"),
    ("predict --model {d}/model.json --data {d}/run.csv --ts 0.5", 2, "disagrees"),
    ("predict --model {d}/model.json --data {d}/run_50hz.csv", 2, "differs from the model's"),
    ("compare --model {d}/model.json --data {d}/run_50hz.csv", 2, "differs from the model's"),
    ("quantize --model {d}/model.json --out {d}/absent/m.bin", 2, "does not exist"),
    ("quantize --model {d}/model.json --out {d}/m.bin --input-range nan 1", 2, "finite"),
    ("quantize --model {d}/model.json --out {d}/m.bin --data {d}/nan.csv", 2, "line 9"),
    ("quantize --model {d}/nan_model.json --out {d}/m.bin", 4, "non-finite"),
    ("quantize --model {d}/model.json --out {d}/m.bin --model-id 0x1FFFFFFFF", 2, "32 bits"),
    ("simulate contractor -e step_10 --rate 1e9 --out {d}/sim", 2, "Hz"),
    ("simulate contractor -e step_10 --out {d}/exists", 2, "is a file"),
    ("emulator --listen tcp://127.0.0.1:99999 --duration 1", 2, "0..65535"),
    ("emulator --duration -1", 2, ">= 0"),
    ("emulator --realtime --speed 0 --duration 1", 2, "positive"),
    ("verify --port socket://127.0.0.1:1 --model {d}/model.bin --data {d}/header_only.csv", 2, "no data rows"),
    ("diagnose --data {d}/run.csv --input dR_0 --output strain_0 --ts inf --baseline linear", 2, "positive finite"),
    ("diagnose --data {d}/run.csv --input dR_0 --output strain_0 --ts 1 --baseline linear", 2, "disagrees"),
    ("infoam calibrate --coil-radii {d}/radii.csv", 2, "positive"),
    ("compare --model {d}/model.json --data {d}/header_only.csv", 2, "no data rows"),
    ("predict --model {d}/model.json --data {d}/header_only.csv", 2, "no data rows"),
    ("export --model {d}/model.json", 2, "--c"),
    ("report --data {d}/run.csv --model {d}/nan_model.json --out {d}/rep", 4, "non-finite"),
]


@pytest.mark.parametrize(
    "args,code,words", CASES, ids=[c[0].split(" {d}")[0][:40] + f"#{i}" for i, c in enumerate(CASES)]
)
def test_failure_is_one_line_with_its_exit_code(work, args, code, words, capsys):
    # In process: an exception that escapes main() is a traceback and fails the test.
    argv = [a.replace("{d}", str(work)) for a in args.split()]
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == code, f"{args}: exit {rc}\n{err[-1500:]}"
    assert len(err.splitlines()) == 1, err[-1500:]
    assert words in err, err


@pytest.mark.parametrize(
    "args,code",
    [
        ("identify --data {d}/run.csv --input dR_0 --output strain_0 --ts 0.5", 2),
        ("predict --model {d}/nan_model.json --data {d}/run.csv", 4),
    ],
)
def test_process_exit_code_and_no_traceback(work, args, code):
    argv = [a.replace("{d}", str(work)) for a in args.split()]
    proc = subprocess.run([sys.executable, "-m", "porosense", *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == code and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_no_command_exits_1():
    proc = subprocess.run([sys.executable, "-m", "porosense"], capture_output=True, text=True)
    assert proc.returncode == 1


def test_closed_pipe_stops_quietly():
    """`porosense bench protocol --json | head -0`, unbuffered so that the first print meets the
    closed pipe (the reader closes before the interpreter has imported porosense). The command
    stops with the shell's SIGPIPE status (141) and no traceback or 'Exception ignored' message."""
    proc = subprocess.Popen(
        [sys.executable, "-u", "-m", "porosense", "bench", "protocol", "--size", "small", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()
    _, err = proc.communicate(timeout=120)
    err = err.decode()
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert proc.returncode == 141
