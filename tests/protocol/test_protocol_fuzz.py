"""The C++ frame decoder under AddressSanitizer + UndefinedBehaviorSanitizer, fed random and
mutated streams (tests/core/fuzz_frame_decoder.cpp checks the invariants and aborts on any
violation or sanitizer finding)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from protocol_testing import ROOT

CORE_TESTS = ROOT / "tests" / "core"
pytestmark = pytest.mark.xdist_group("protocol-fuzz")


@pytest.fixture(scope="module")
def fuzzer() -> Path:
    if shutil.which("g++") is None:
        pytest.skip("g++ not installed")
    proc = subprocess.run(["make", "-s", "-f", "Makefile.fuzz"], cwd=CORE_TESTS, capture_output=True, text=True)
    assert proc.returncode == 0, f"fuzz driver build failed:\n{proc.stdout}\n{proc.stderr}"
    return CORE_TESTS / "build" / "fuzz_frame_decoder"


def _run(exe: Path, inputs: int, seed: int) -> dict:
    proc = subprocess.run([str(exe), str(inputs), str(seed)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"fuzzing failed (exit {proc.returncode}):\n{proc.stdout}\n{proc.stderr[-3000:]}"
    figures = json.loads(proc.stdout.strip().splitlines()[-1])
    print(figures)
    return figures


def _assert_sound(figures: dict, inputs: int) -> None:
    assert figures["inputs"] == inputs
    assert figures["bytes"] > 100 * inputs  # the streams were not trivially short
    assert figures["frames_after_garbage"] > inputs  # the recovery was exercised
    assert figures["recovered_after_garbage"] == figures["frames_after_garbage"]


def test_decoder_survives_100k_fuzz_inputs(fuzzer):
    _assert_sound(_run(fuzzer, 100_000, seed=1), 100_000)


@pytest.mark.slow
def test_decoder_survives_1m_fuzz_inputs(fuzzer):
    _assert_sound(_run(fuzzer, 1_000_000, seed=2), 1_000_000)
