"""Measure Estimator::step in AVR cycles: build the packaged program cycles.cpp
(porosense/firmware/programs) with avr-g++ -Os for the ATmega328P around a model blob and run
it in simavr (Timer1 at the CPU clock). Also checks the AVR build (assembly included) bit for
bit against the Python reference on many models (vectors.cpp)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from porosense.firmware.files import core_dir, programs_dir  # noqa: E402
from porosense.protocol.model_blob import ModelBlob
from porosense.quant.fixed import FixedPointEstimator

CORE = core_dir()
PROGRAM = programs_dir() / "cycles.cpp"
VECTORS_PROGRAM = programs_dir() / "vectors.cpp"
CORE_SOURCES = ("estimator.cpp", "model_blob.cpp", "frame_codec.cpp", "control.cpp")


@dataclass
class CycleResult:
    max_cycles: int
    mean_cycles: int
    steps: int
    estimator_ram: int  # sizeof(est::Estimator) on the AVR
    text: int  # flash bytes of the test program
    in_eeprom: bool
    bit_exact: bool  # the AVR's estimates hash equals the Python reference's
    control_cycles: int = 0  # worst ctl::Controller::step on 3 channels (firmware/lib/core/control.h)

    @property
    def sample_cycles(self) -> int:
        """Estimator and controller together: what one controlled sample adds to the budget."""
        return self.max_cycles + self.control_cycles


def program_inputs(steps: int) -> np.ndarray:
    """The inputs cycles.cpp feeds the estimator (0.01 %), shape (steps, 3)."""
    t = np.arange(steps)
    level = np.where((t // 16) & 1, -8000, 500)
    return np.stack([level, -level // 2, level + 37 * (t & 7)], axis=1)  # levels are even: // is C's /


def reference_check(blob: ModelBlob, steps: int) -> int:
    """The hash cycles.cpp computes, from the Python reference."""
    est, flags = FixedPointEstimator(blob).run(program_inputs(steps))
    check = 0
    for row, fl in zip(est, flags):
        for v in row:
            check = (check * 31 + (int(v) & 0xFFFF)) & 0xFFFFFFFF
        check = (check * 31 + int(fl)) & 0xFFFFFFFF
    return check


def available() -> str | None:
    """None when avr-g++ and simavr are installed, else what is missing."""
    missing = [t for t in ("avr-g++", "simavr") if shutil.which(t) is None]
    if not PROGRAM.exists():
        missing.append(str(PROGRAM))
    return ", ".join(missing) or None


def measure(
    blob: ModelBlob | bytes, *, in_eeprom: bool = False, steps: int = 64, timeout: float = 120.0
) -> CycleResult:
    """Worst and mean cycles of one step over ``steps`` samples of switching inputs."""
    if not isinstance(blob, ModelBlob):
        blob = ModelBlob.from_bytes(bytes(blob), max_length=4096)
    data = blob.to_bytes()
    with tempfile.TemporaryDirectory(prefix="porosense-cycles-") as tmp:
        tmp = Path(tmp)
        rows = ",\n".join("  " + ", ".join(f"0x{v:02X}" for v in data[i : i + 16]) for i in range(0, len(data), 16))
        (tmp / "model.h").write_text(
            "#pragma once\n#include <avr/pgmspace.h>\n"
            f"#define MODEL_LEN {len(data)}u\n#define MODEL_STEPS {steps}u\n"
            f"#define MODEL_IN_EEPROM {int(in_eeprom)}\n"
            f"static const uint8_t MODEL_BLOB[{len(data)}] PROGMEM = {{\n{rows}\n}};\n"
        )
        elf = _build(PROGRAM, tmp, tmp / "cycles.elf", "atmega328p")
        size = subprocess.run(["avr-size", str(elf)], capture_output=True, text=True).stdout.split("\n")[1].split()
        run = subprocess.run(
            ["simavr", "-m", "atmega328p", "-f", "16000000", str(elf)], capture_output=True, text=True, timeout=timeout
        )
        out = run.stdout + run.stderr
        m = re.search(r"cycles max=(\d+) mean=(\d+) steps=(\d+) ram=(\d+) check=(\d+) ctl=(\d+)", out)
        if not m:
            raise RuntimeError(f"simavr gave no cycle count:\n{out[-2000:]}")
        exact = int(m[5]) == reference_check(blob, steps)
        return CycleResult(int(m[1]), int(m[2]), int(m[3]), int(m[4]), int(size[0]), in_eeprom, exact, int(m[6]))


def _build(program: Path, include: Path, elf: Path, mcu: str) -> Path:
    """avr-g++ -Os of ``program`` with the estimator's sources (``include`` holds its header)."""
    cmd = [
        "avr-g++",
        "-std=c++11",
        os.environ.get("POROSENSE_AVR_OPT", "-Os"),
        f"-mmcu={mcu}",
        "-DF_CPU=16000000UL",
        "-fno-exceptions",
        "-ffunction-sections",
        "-fdata-sections",
        "-Wl,--gc-sections",
        f"-I{CORE}",
        f"-I{include}",
        "-o",
        str(elf),
        str(program),
        *[str(CORE / s) for s in CORE_SOURCES],
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"avr-g++ failed:\n{proc.stderr}")
    return elf


def _hash(est: np.ndarray, flags: np.ndarray) -> int:
    check = 0
    for row, fl in zip(est, flags):
        for v in row:
            check = (check * 31 + (int(v) & 0xFFFF)) & 0xFFFFFFFF
        check = (check * 31 + int(fl)) & 0xFFFFFFFF
    return check


def check_vectors(cases, *, timeout: float = 300.0) -> list[bool]:
    """Run bit-exactness cases [(blob bytes, inputs (N, 3), estimates (N, 3), flags (N,))] (all
    with the same N, as tests/quant/vectors.make_cases gives) through the AVR build in simavr
    (an ATmega1284P, for the flash the cases need; same core and multiplier as the ATmega328P).
    Returns, per case, whether the AVR's estimates and flags hash to the reference's."""
    # Program-memory data must stay below 64 KB (16-bit pgm_read pointers): batches of cases.
    batches, size = [[]], 0
    for case in cases:
        nbytes = len(case[0]) + 6 * len(case[1])
        if batches[-1] and size + nbytes > 48_000:
            batches.append([])
            size = 0
        batches[-1].append(case)
        size += nbytes
    return [ok for batch in batches for ok in _check_batch(batch, timeout)]


def _check_batch(cases, timeout: float) -> list[bool]:
    n = len(cases[0][1])
    lines = ["#pragma once", "#include <avr/pgmspace.h>", f"#define N_CASES {len(cases)}u", f"#define N_SAMPLES {n}u"]
    for i, (blob, u, _, _) in enumerate(cases):
        lines.append(f"static const uint8_t BLOB{i}[] PROGMEM = {{{', '.join(str(b) for b in bytes(blob))}}};")
        flat = np.asarray(u, dtype=np.int64).reshape(-1)
        lines.append(f"static const int16_t IN{i}[] PROGMEM = {{{', '.join(str(int(v)) for v in flat)}}};")
    lines.append(f"static const uint16_t CASE_LEN[] PROGMEM = {{{', '.join(str(len(c[0])) for c in cases)}}};")
    lines.append(
        "static const uint8_t* const CASE_BLOB[] PROGMEM = {" + ", ".join(f"BLOB{i}" for i in range(len(cases))) + "};"
    )
    lines.append(
        "static const int16_t* const CASE_INPUTS[] PROGMEM = {" + ", ".join(f"IN{i}" for i in range(len(cases))) + "};"
    )
    with tempfile.TemporaryDirectory(prefix="porosense-vectors-") as tmp:
        tmp = Path(tmp)
        (tmp / "vectors.h").write_text("\n".join(lines) + "\n")
        elf = _build(VECTORS_PROGRAM, tmp, tmp / "vectors.elf", "atmega1284p")
        run = subprocess.run(
            ["simavr", "-m", "atmega1284p", "-f", "16000000", str(elf)], capture_output=True, text=True, timeout=timeout
        )
    got = {int(m[1]): int(m[2]) for m in re.finditer(r"case (\d+) check=(\d+)", run.stdout + run.stderr)}
    return [got.get(i) == _hash(est, flags) for i, (_, _, est, flags) in enumerate(cases)]
