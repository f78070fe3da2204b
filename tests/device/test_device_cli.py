"""The `porosense ports` and `porosense emulator` commands."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from porosense.cli import main
from porosense.device import Device


def test_ports_json(capsys):
    assert main(["ports", "--json"]) == 0
    ports = json.loads(capsys.readouterr().out)
    assert isinstance(ports, list)
    assert all({"device", "vid", "pid", "likely_uno"} <= set(p) for p in ports)


def test_emulator_command_serves_a_board():
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "porosense",
            "emulator",
            "--listen",
            "tcp://127.0.0.1:0",
            "--actuator",
            "3dof",
            "--duration",
            "30",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        url = next(w for w in line.split() if w.startswith("socket://"))
        with Device.open(url, handshake_timeout_s=5.0) as dev:
            assert dev.info.emulated and dev.info.n_channels == 3
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["emulator", "--listen", "udp://1.2.3.4:5", "--duration", "0"], "cannot listen"),
        (["emulator", "--corrupt", "2", "--duration", "0"], "probability"),
    ],
)
def test_emulator_mistakes_are_one_line_errors(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
