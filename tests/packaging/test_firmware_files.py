"""The packaged firmware files: the host core library's build, `porosense firmware upload`
(with a stand-in avrdude that records its arguments), and their one-line errors."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from porosense.firmware import files, hostlib


def _cli(args, env=None, cwd=None):
    full = {**os.environ, **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "porosense", *args], capture_output=True, text=True, env=full, cwd=cwd, timeout=300
    )


def test_package_finds_its_files_without_the_repository_layout():
    assert (files.core_dir() / "host_api.h").is_file() and (files.core_dir() / "device.cpp").is_file()
    assert files.core_dir().parent == Path(hostlib.__file__).resolve().parent
    names = [p.name for p in hostlib.sources()]
    assert "host_api.cpp" in names and "device.cpp" in names and "estimator.cpp" in names


def test_library_digest_follows_the_sources(tmp_path):
    src = tmp_path / "core"
    src.mkdir()
    for p in hostlib.sources():
        (src / p.name).write_bytes(p.read_bytes())
    before = hostlib.digest(src)
    assert before == hostlib.digest()
    (src / "device.cpp").write_text((src / "device.cpp").read_text() + "\n// changed\n")
    assert hostlib.digest(src) != before  # a firmware change rebuilds the emulator's core


def test_missing_compiler_is_one_clear_line(tmp_path):
    proc = _cli(
        ["emulator", "--listen", "tcp://127.0.0.1:0", "--duration", "0.1"],
        env={"CXX": str(tmp_path / "no-such-c++"), "POROSENSE_CACHE": str(tmp_path / "cache")},
    )
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 3, proc.stderr
    assert len(lines) == 1 and "C++ compiler" in lines[0] and "apt-get install g++" in lines[0]


def _fake_avrdude(tmp_path: Path, exit_code: int, message: str) -> Path:
    tool = tmp_path / "avrdude"
    log, said = tmp_path / "avrdude.args", tmp_path / "avrdude.says"
    said.write_text(message + "\n")
    tool.write_text(f'#!/bin/sh\necho "$@" > {log}\ncat {said} >&2\nexit {exit_code}\n')
    tool.chmod(tool.stat().st_mode | stat.S_IEXEC)
    return tool


def test_upload_flashes_the_packaged_hex_with_avrdude(tmp_path):
    if not files.hex_path().is_file():
        pytest.skip("no firmware HEX packaged (gcc-avr absent: make -C firmware)")
    tool = _fake_avrdude(tmp_path, 0, "avrdude done.  Thank you.")
    proc = _cli(["firmware", "upload", "--port", "/dev/ttyACM7", "--avrdude", str(tool)])
    assert proc.returncode == 0, proc.stderr
    args = (tmp_path / "avrdude.args").read_text().split()
    assert args[args.index("-p") + 1] == "atmega328p" and args[args.index("-c") + 1] == "arduino"
    assert args[args.index("-P") + 1] == "/dev/ttyACM7" and args[args.index("-b") + 1] == "115200"
    assert args[args.index("-U") + 1] == f"flash:w:{files.hex_path()}:i"
    assert "Thank you" in proc.stdout


def test_upload_failures_are_one_line(tmp_path):
    tool = _fake_avrdude(tmp_path, 1, 'avrdude: ser_open(): can\'t open device "/dev/ttyACM7"')
    hex_file = tmp_path / "fw.hex"
    hex_file.write_text(":020000000C945E\n:00000001FF\n")  # one jmp word: an image avrdude is given
    proc = _cli(["firmware", "upload", "--port", "/dev/ttyACM7", "--avrdude", str(tool), "--hex", str(hex_file)])
    assert proc.returncode == 3 and len(proc.stderr.strip().splitlines()) == 1
    assert "can't open device" in proc.stderr
    hex_file.write_text(":00000001FF\n")  # no data: refused before avrdude runs
    proc = _cli(["firmware", "upload", "--port", "/dev/ttyACM7", "--avrdude", str(tool), "--hex", str(hex_file)])
    assert proc.returncode == 2 and "holds no data" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    proc = _cli(["firmware", "upload", "--port", "/dev/ttyACM7", "--hex", str(tmp_path / "absent.hex")])
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "no firmware HEX" in proc.stderr
