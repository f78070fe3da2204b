"""The C++ frame decoder under AddressSanitizer + UndefinedBehaviorSanitizer, fed random and
mutated streams (tests/core/fuzz_frame_decoder.cpp checks the invariants and aborts on any
violation or sanitizer finding)."""

from __future__ import annotations

import json
import random
import shutil
import subprocess
from pathlib import Path

import pytest
from protocol_testing import ROOT, vectors

from porosense.protocol import FrameDecoder

CORE_TESTS = ROOT / "tests" / "core"
pytestmark = pytest.mark.xdist_group("protocol-fuzz")


@pytest.fixture(scope="module")
def fuzzer() -> Path:
    if shutil.which("g++") is None:
        pytest.skip("g++ not installed")
    proc = subprocess.run(["make", "-s", "-f", "Makefile.fuzz"], cwd=CORE_TESTS, capture_output=True, text=True)
    assert proc.returncode == 0, f"fuzz driver build failed:\n{proc.stdout}\n{proc.stderr}"
    return CORE_TESTS / "build" / "fuzz_frame_decoder"


@pytest.fixture(scope="module")
def cpp_lines(fuzzer) -> Path:
    return fuzzer.parent / "fuzz_decode_lines"


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


def _random_streams(n: int, seed: int) -> list[bytes]:
    """Seeded streams built from the golden frames: damaged, glued to garbage, or noise."""
    rng = random.Random(seed)
    frames = [bytes.fromhex(v["frame"]) for v in vectors()["frames"]]
    streams = []
    for _ in range(n):
        kind = rng.randrange(4)
        if kind == 0:
            s = bytes(rng.randrange(256) for _ in range(rng.randrange(400)))
        else:
            parts = []
            for _ in range(rng.randrange(1, 4)):
                junk = bytes(rng.randrange(0 if kind == 1 else 1, 256) for _ in range(rng.randrange(200)))
                parts += [junk, rng.choice(frames)]
            s = bytearray(b"".join(parts))
            for _ in range(rng.randrange(4) if kind == 3 else 0):  # a few flips, insertions, deletions
                at = rng.randrange(len(s))
                op = rng.randrange(3)
                if op == 0:
                    s[at] ^= 1 << rng.randrange(8)
                elif op == 1:
                    s.insert(at, rng.randrange(256))
                else:
                    del s[at]
            s = bytes(s)
        streams.append(s)
    return streams


def _python_lines(streams: list[bytes]) -> list[str]:
    out = []
    for s in streams:
        dec = FrameDecoder()
        frames = dec.feed(s)
        c = dec.counters
        line = " ".join(
            str(c[k])
            for k in ("frames", "bad_cobs", "bad_crc", "bad_length", "bad_version", "unknown_type", "overlong")
        )
        line += "".join(f" {f.version}:{f.type}:{f.seq}:{f.payload.hex() or '-'}" for f in frames)
        out.append(line)
    return out


def _differential(exe: Path, n: int, seed: int) -> None:
    streams = _random_streams(n, seed)
    proc = subprocess.run(
        [str(exe)], input="".join(s.hex() + "\n" for s in streams), capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    cpp = proc.stdout.splitlines()
    py = _python_lines(streams)
    assert len(cpp) == len(py) == n
    differ = [i for i in range(n) if cpp[i] != py[i]]
    assert not differ, f"{len(differ)} of {n} streams decoded differently; first: {streams[differ[0]].hex()}"
    assert sum(int(line.split()[0]) for line in py) > n // 2  # frames did come through


def test_cpp_and_python_decoders_agree_on_random_streams(cpp_lines):
    _differential(cpp_lines, 1500, seed=3)


@pytest.mark.slow
def test_cpp_and_python_decoders_agree_on_random_streams_many(cpp_lines):
    """5,000 streams: a disagreement on 1 in 1,700 streams is found with probability 95 %."""
    _differential(cpp_lines, 5000, seed=4)
