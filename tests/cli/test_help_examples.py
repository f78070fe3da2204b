"""Every example printed by ``porosense COMMAND --help`` runs as printed, against the emulator
(through the command's entry point in this process; tests/cli/test_readme_workflow.py runs the
README's workflow as separate processes).

The examples name files (step_20.csv, model.json, ...) that a user has after the earlier steps;
the test makes the recordings with the simulator (50 Hz, CI-sized) in a fresh folder and runs
the examples in workflow order, each in that folder, as a user would type them. Device examples
talk to ``porosense emulator`` started with its own printed example (tcp://127.0.0.1:5000).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import resource
import shlex
import socket
import subprocess
import sys
import time

import pytest

from porosense.cli import build_parser, main

# Examples that cannot run here as printed, and where they are covered instead.
COVERED_ELSEWHERE = {
    "calibrate": "its examples name a user's measured records; tests/sim/test_calibrate.py runs both forms",
    "compensate": "its example names records under a load; tests/cli/test_compensate.py runs it on simulated ones",
    "demo": "tests/workflows runs `porosense demo` end to end (minutes per actuator)",
    "firmware": "uploading needs a board; tests/packaging runs `firmware upload` with a stand-in avrdude",
    "record": "needs a camera; tests/record runs `porosense record` on rendered video and the emulator",
}
ORDER = (
    "simulate",
    "identify",
    "predict",
    "compare",
    "report",
    "export",
    "quantize",
    "diagnose",
    "emulator",
    "flash",
    "verify",
    "control",
    "config",
    "ports",
    "infoam",
    "bench",
)
EMULATOR_PORT = 5000


def help_examples() -> dict:
    """{command: [example lines]} from every subcommand's epilog (comments removed)."""
    parser = build_parser()
    subs = parser._subparsers._group_actions[0].choices
    out = {}
    for name, sub in subs.items():
        lines = []
        for raw in (sub.epilog or "").splitlines():
            line = raw.split("  #", 1)[0].strip()
            for prefix in (
                "examples (on the emulator, porosense emulator; a board is --port /dev/ttyACM0):",
                "examples:",
                "example:",
                "then:",
            ):
                if line.startswith(prefix):
                    line = line[len(prefix) :].strip()
            if line.startswith(("porosense ", "python -c")):
                lines.append(line)
        out[name] = lines
    return out


def test_every_command_prints_an_example():
    examples = help_examples()
    assert set(examples) <= set(ORDER) | set(COVERED_ELSEWHERE)
    for name, lines in examples.items():
        assert lines, f"{name} --help shows no runnable example"


def _argv(line: str) -> list[str]:
    words = shlex.split(line)
    if words[0] == "porosense":
        return [sys.executable, "-m", "porosense", *words[1:]]
    return [sys.executable, *words[1:]]  # python -c ...


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _cpu_s() -> float:
    """CPU time of this process and its finished children (s)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _run_example(line: str, work) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of one printed example run in ``work``. `porosense ...`
    lines run through the console script's own entry point (porosense.cli.main) in this process:
    the same parser and code as the installed command, without starting a Python and importing
    numpy and scipy again for each of some thirty examples. Anything else runs as a process."""
    words = shlex.split(line)
    if words[0] != "porosense":
        proc = subprocess.run(_argv(line), cwd=work, capture_output=True, text=True, timeout=600)
        return proc.returncode, proc.stdout, proc.stderr
    out, err = io.StringIO(), io.StringIO()
    here = os.getcwd()
    try:
        os.chdir(work)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(words[1:])
            except SystemExit as exc:  # argparse refuses a usage error
                rc = exc.code if isinstance(exc.code, int) else 2
    finally:
        os.chdir(here)
    return rc, out.getvalue(), err.getvalue()


@pytest.mark.slow
@pytest.mark.xdist_group("help_examples")
def test_help_examples_run_as_printed(tmp_path):
    if not _port_free(EMULATOR_PORT):
        pytest.skip(f"port {EMULATOR_PORT} is in use: the printed device examples need it")
    work = tmp_path
    sim = subprocess.run(
        _argv(
            f"porosense simulate contractor -e staircase -e step_10 -e step_20 -e step_40 -e step_60 --rate 50 "
            f"--out {work} --json"
        ),
        capture_output=True,
        text=True,
        check=True,
    )
    for item in json.loads(sim.stdout):
        src = work / item["path"].rsplit("/", 1)[-1]
        src.rename(work / f"{item['experiment']}.csv")
        src.with_suffix(".json").rename(work / f"{item['experiment']}.json")
    (work / "run.csv").write_bytes((work / "step_40.csv").read_bytes())
    # The simulator's parameter file a user has from `porosense calibrate` (covered elsewhere):
    # here the built-in contractor's.
    from porosense.sim import make_plant

    make_plant("contractor").physics.save(work / "params.json")
    (work / "run.json").write_bytes((work / "step_40.json").read_bytes())

    examples = help_examples()
    emulator = None
    ran = []
    try:
        for name in ORDER:
            for line in examples.get(name, []):
                if name == "emulator" and line.startswith("porosense emulator"):
                    emulator = subprocess.Popen(_argv(line), cwd=work, stdout=subprocess.PIPE, text=True)
                    announced = emulator.stdout.readline()
                    assert f":{EMULATOR_PORT}" in announced, announced
                    ran.append(line)
                    continue
                t0, cpu0 = time.perf_counter(), _cpu_s()
                rc, out, err = _run_example(line, work)
                print(f"{time.perf_counter() - t0:6.1f} s  {_cpu_s() - cpu0:5.1f} s CPU  rc {rc}  {line}")
                assert rc == 0, f"{line}\n{out[-2000:]}\n{err[-2000:]}"
                assert "Traceback" not in err
                ran.append(line)
    finally:
        if emulator is not None:
            emulator.terminate()
            emulator.wait(timeout=30)
    expected = sum(len(v) for k, v in examples.items() if k not in COVERED_ELSEWHERE)
    assert len(ran) == expected
    # What the examples promised to write is there.
    for path in (
        "runs",
        "model.json",
        "report.json",
        "pred.csv",
        "pred.png",
        "compare.png",
        "report/report.html",
        "model.c",
        "model_tf.json",
        "model.bin",
        "quant.json",
        "diag.json",
        "diag/summary.md",
        "my_contractor.json",
        "contractor.gcode",
        "c.png",
        "bending.gcode",
        "segment.gcode",
        "parts",
        "build",
    ):
        assert (work / path).exists(), path
