"""Protocol benchmark: codec throughput (Python and C++) and what the serial link carries.

``run("small")`` takes a few seconds; ``run("full")`` times ten times more frames. The link
figures (SAMPLE frame size and highest rate at 115200 baud) do not depend on the size: they
come from the real encoder.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from porosense.firmware.files import source_tree
from porosense.protocol import FrameDecoder, Sample, encode_message

BAUD = 115200
BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit
_TREE = source_tree()
CPP_BENCH_DIR = _TREE / "tools" / "bench" / "protocol" if _TREE else Path("tools/bench/protocol (not installed)")
SIZES = {"small": (5_000, 300_000), "full": (50_000, 3_000_000)}  # Python frames, C++ frames


@dataclass
class ProtocolBenchResult:
    """Figures of the protocol benchmark (rates in frames per second)."""

    size: str
    sample_payload_bytes: int
    sample_frame_bytes: int  # on the wire, delimiter included, worst case over contents
    sample_max_rate_hz: float  # at BAUD with BITS_PER_BYTE
    link_use_at_200hz: float  # fraction of the device -> host link
    python_encode_fps: float
    python_decode_fps: float
    cpp_encode_fps: float | None
    cpp_decode_fps: float | None
    cpp_note: str = ""
    avr_cycles: dict | None = None  # decoder/encoder cycles per call on the Uno (simavr)
    avr_note: str = ""
    summary: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)


def _samples(n: int):

    return [
        Sample(
            t_us=i * 5000 & 0xFFFFFFFF,
            channel_mask=0x1F,
            status=i & 0x0F,
            adc=tuple(20000 + (i * 37 + c * 11) % 4000 for c in range(3)),
            dr_centi=tuple(-((i * 13 + c) % 8000) for c in range(3)),
            euler_16=tuple((i * 7 + c * 100) % 5760 for c in range(3)),
            estimate=tuple((i * 3 + c) % 30000 for c in range(3)),
        )
        for i in range(n)
    ]


def sample_frame_bytes() -> int:
    """Largest SAMPLE frame on the wire over extreme contents (all 0x00, no 0x00, mixed)."""

    cases = [
        Sample(),
        Sample(
            t_us=0xFFFFFFFF,
            channel_mask=0xFF,
            status=0xFFFF,
            adc=(-1,) * 3,
            dr_centi=(-1,) * 3,
            euler_16=(-1,) * 3,
            estimate=(-1,) * 3,
        ),
        *_samples(64),
    ]
    return max(len(encode_message(s, seq)) for seq, s in enumerate(cases))


def _python_rates(n: int) -> tuple[float, float]:

    samples = _samples(min(n, 1024))
    t0 = time.perf_counter()
    frames = [encode_message(samples[i % len(samples)], i & 0xFF) for i in range(n)]
    t_encode = time.perf_counter() - t0
    stream = b"".join(frames)
    dec = FrameDecoder()
    t0 = time.perf_counter()
    decoded = 0
    for i in range(0, len(stream), 64):  # the size of a typical serial read
        decoded += len(dec.feed(stream[i : i + 64]))
    t_decode = time.perf_counter() - t0
    if decoded != n:
        raise RuntimeError(f"Python decoder returned {decoded} of {n} frames")
    return n / t_encode, n / t_decode


def _cpp_rates(n: int) -> tuple[float | None, float | None, str]:
    if not (CPP_BENCH_DIR / "codec_bench.cpp").exists():
        return None, None, "C++ benchmark source not found (installed without the repository)"
    if shutil.which("g++") is None or shutil.which("make") is None:
        return None, None, "g++ or make not installed"
    build = subprocess.run(["make", "-s", "-C", str(CPP_BENCH_DIR)], capture_output=True, text=True)
    if build.returncode != 0:
        return None, None, f"C++ benchmark build failed: {build.stderr.strip()[-300:]}"
    proc = subprocess.run(
        [str(CPP_BENCH_DIR / "build" / "codec_bench"), str(n)], capture_output=True, text=True, timeout=300
    )
    if proc.returncode != 0:
        return None, None, f"C++ benchmark failed: {proc.stderr.strip()[-300:]}"
    figures = json.loads(proc.stdout)
    return figures["encode_frames_per_s"], figures["decode_frames_per_s"], "g++ -O2 on this host"


def _avr_cycles() -> tuple[dict | None, str]:
    """Cycles of the decoder on the ATmega328P in simavr (tools/bench/protocol/avr_decode.cpp)."""
    if not (CPP_BENCH_DIR / "avr_decode.cpp").exists():
        return None, "AVR benchmark source not found"
    if shutil.which("avr-g++") is None or shutil.which("pkg-config") is None:
        return None, "avr-g++ or pkg-config not installed"
    build = subprocess.run(["make", "-s", "-C", str(CPP_BENCH_DIR), "avr"], capture_output=True, text=True)
    if build.returncode != 0:
        return None, f"AVR benchmark build failed: {build.stderr.strip()[-300:]}"
    proc = subprocess.run(
        [str(CPP_BENCH_DIR / "build" / "avr_cycles"), str(CPP_BENCH_DIR / "build" / "avr_decode.elf")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    if proc.returncode != 0:
        return None, f"simavr run failed: {proc.stderr.strip()[-300:]}"
    figures = json.loads(proc.stdout.strip().splitlines()[-1])
    return figures, "ATmega328P at 16 MHz in simavr"


def run(size: str = "small") -> dict:
    """Run the benchmark; returns the figures as a dict with a ``summary`` of lines."""

    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)}")
    n_py, n_cpp = SIZES[size]
    frame_bytes = sample_frame_bytes()
    max_rate = BAUD / (BITS_PER_BYTE * frame_bytes)
    py_enc, py_dec = _python_rates(n_py)
    cpp_enc, cpp_dec, note = _cpp_rates(n_cpp)
    avr, avr_note = _avr_cycles()
    result = ProtocolBenchResult(
        size=size,
        sample_payload_bytes=Sample.MIN_LEN,
        sample_frame_bytes=frame_bytes,
        sample_max_rate_hz=round(max_rate, 1),
        link_use_at_200hz=round(200 / max_rate, 3),
        python_encode_fps=round(py_enc),
        python_decode_fps=round(py_dec),
        cpp_encode_fps=cpp_enc,
        cpp_decode_fps=cpp_dec,
        cpp_note=note,
        avr_cycles=avr,
        avr_note=avr_note,
    )

    def rate(x):
        return f"{x:,.0f} frames/s" if x is not None else f"n/a ({note})"

    result.summary = [
        f"SAMPLE frame (3 channels, IMU, 3 estimates): {Sample.MIN_LEN}-byte payload, {frame_bytes} bytes on the wire",
        f"highest SAMPLE rate at {BAUD} baud 8N1: {max_rate:.1f} Hz (200 Hz uses {200 / max_rate:.0%} of the link)",
        f"Python codec: encode {rate(py_enc)}, decode {rate(py_dec)} (SAMPLE frames, {n_py:,} each)",
        f"C++ codec on this host: encode {rate(cpp_enc)}, decode {rate(cpp_dec)} ({n_cpp:,} each, byte by byte)",
    ]
    if avr:
        us = 1e6 / avr["f_cpu_hz"]
        result.summary.append(
            f"on the Uno (16 MHz): encode a SAMPLE {avr['encode_sample'] * us:.0f} us, decode a SAMPLE "
            f"{avr['valid_frame_delimiter'] * us:.0f} us at its delimiter, worst bad 129-byte chunk "
            f"{max(avr['worst_bad_chunk_delimiter'], avr['adversarial_chunk_delimiter']) * us:.0f} us"
        )
    else:
        result.summary.append(f"on the Uno: n/a ({avr_note})")
    return result.to_dict()
