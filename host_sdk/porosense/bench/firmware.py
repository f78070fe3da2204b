"""Firmware budgets: flash and static RAM from avr-size, stack headroom, the estimator's
worst-case step in cycles, overruns at 100 Hz and at the advertised highest rate in the
simboard, and the highest sample rate each channel configuration sustains with no sample
lost (searched with a build whose START_STREAM limit is raised). The advertised
SAMPLE_RATE_HZ maximum (protocol/messages.toml, the one source) must equal the highest clean
rate of every channel + IMU + the heaviest storable model (a flash store slot's); the bench
prints both and fails when they differ. To set it after a firmware change: run
``porosense bench firmware --size full``, put the measured rate into SAMPLE_RATE_HZ's ``max``
and run ``python protocol/generate.py``.

``porosense bench firmware --json`` prints them. Budgets: flash <= 30,208 B (the flash model
store sits above), static
RAM (data + bss) <= 1,400 bytes, estimator step <= 48,000 cycles, zero overruns over 60 s
of simulated time at 100 Hz with 3 ADC channels + IMU + estimator + telemetry.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from porosense.firmware.files import elf_path, source_tree
from porosense.firmware.flash_store import upload
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey
from porosense.protocol.model_layout import MAX_BLOB_LEN
from porosense.quant.design import design_blob
from porosense.quant.quantize import quantize
from porosense.quant.random_models import random_structure

_TREE = source_tree()
FIRMWARE_DIR = _TREE / "firmware" if _TREE else None  # None: installed, nothing to rebuild
ELF = elf_path()


FLASH_BUDGET = 30208  # bytes: below the flash model store (30,208..32,255)
RAM_BUDGET = 1440  # bytes, .data + .bss (firmware/Makefile: measured stack margin)
RAM_TOTAL = 2048  # ATmega328P SRAM
CYCLE_BUDGET = 48_000  # estimator step, cycles at 16 MHz
OVERRUN_RATE_HZ = 100
ESTIMATOR_OFF = 1 << 3  # status flag: no model loaded
MODEL_REGION_BYTES = MAX_BLOB_LEN  # the EEPROM model area (one model alone)
FLASH_SLOT_BYTES = 1016  # blob bytes of one flash store slot (layout.FLASH_BLOB_MAX)
# Candidates for the heaviest model a flash slot holds, most expensive first (3 x 3 WH; poles in
# H1, poles in H2, breakpoints); measured from flash (porosense.firmware.avr_cycles, seed 1) when
# the slots held 1,144 B: 10/10/3 (compact tables, 60 sections) 56,392 cycles, 10/8/4 55,207,
# 10/10/2 48,652. A 1,016-byte slot holds the first that fits there: 927 B, 36,850 cycles.
FLASH_HEAVY_CANDIDATES = ((10, 10, 3), (10, 8, 4), (10, 10, 2), (8, 8, 6), (4, 4, 10))


@dataclass(frozen=True)
class SizeReport:
    """Section sizes of the firmware ELF in bytes."""

    text: int
    data: int
    bss: int
    noinit: int

    @property
    def flash(self) -> int:
        """Program memory used: code + constants + the initial values of .data (bytes)."""
        return self.text + self.data

    @property
    def static_ram(self) -> int:
        """RAM taken before the stack: .data + .bss (bytes)."""
        return self.data + self.bss

    @property
    def stack_room(self) -> int:
        """RAM left for the stack: 2048 - .data - .bss - .noinit (bytes)."""
        return RAM_TOTAL - self.data - self.bss - self.noinit

    def to_dict(self) -> dict:
        d = asdict(self)
        d.update(flash=self.flash, static_ram=self.static_ram, stack_room=self.stack_room)
        return d

    def __str__(self) -> str:
        return (
            f"flash {self.flash} B (<= {FLASH_BUDGET}), static RAM {self.static_ram} B "
            f"(<= {RAM_BUDGET}), {self.stack_room} B left for the stack"
        )


def toolchain_missing() -> str | None:
    """Why the firmware cannot be built here, or None when it can."""
    for tool in ("avr-gcc", "avr-g++", "avr-size", "make"):
        if shutil.which(tool) is None:
            return f"{tool} not installed (Debian: gcc-avr avr-libc binutils-avr)"
    if not Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino").is_dir():
        return "arduino-core-avr not installed (/usr/share/arduino)"
    return None


def build(quiet: bool = True) -> subprocess.CompletedProcess:
    """``make -C firmware``; returns the completed process (output captured). A lock file
    keeps concurrent builds (parallel test workers) from writing the same objects."""
    import fcntl

    args = ["make", "-C", str(FIRMWARE_DIR)]
    if quiet:
        args.insert(1, "-s")
    (FIRMWARE_DIR / "build").mkdir(exist_ok=True)
    with open(FIRMWARE_DIR / "build" / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return subprocess.run(args, capture_output=True, text=True, timeout=600)


def measure_size(elf: Path = ELF) -> SizeReport:
    """Parse ``avr-size -A`` of the ELF into a SizeReport (bytes)."""
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        m = re.match(r"^\.(\w+)\s+(\d+)\s+\d+", line.strip())
        if m:
            sizes[m.group(1)] = int(m.group(2))
    return SizeReport(
        text=sizes.get("text", 0), data=sizes.get("data", 0), bss=sizes.get("bss", 0), noinit=sizes.get("noinit", 0)
    )


def estimator_cycles() -> dict:
    """Cycles of one estimator step on the ATmega328P (simavr), measured with the
    quantization area's harness (porosense.firmware.avr_cycles): the heaviest model that fits
    the EEPROM, read from EEPROM; the heaviest a flash store slot holds, read from flash; the
    issue's nominal worst case (3 x 3, 10 poles per block, 16 breakpoints), which no store
    holds, from flash."""
    try:
        from porosense.firmware import avr_cycles
    except ImportError as exc:
        return {"status": "pending", "reason": f"porosense.firmware.avr_cycles not available ({exc})"}
    missing = avr_cycles.available()
    if missing:
        return {"status": "pending", "reason": f"missing: {missing}"}
    try:
        blob = heavy_model_blob()
        r = avr_cycles.measure(blob, in_eeprom=True)
        w = avr_cycles.measure(worst_case_blob())
        fblob = heaviest_storable_blob()
        fr = avr_cycles.measure(fblob, in_eeprom=False)
    except Exception as exc:  # a toolchain problem is reported, not raised
        return {"status": "pending", "reason": f"{type(exc).__name__}: {exc}"}
    return {
        "status": "measured",
        "model_bytes": len(blob),
        "cycles": int(r.max_cycles),
        "flash_model_bytes": len(fblob),
        "flash_model_cycles": int(fr.max_cycles),
        "flash_model_mean_cycles": int(fr.mean_cycles),
        "flash_model_bit_exact": bool(fr.bit_exact),
        "flash_model_ok": fr.max_cycles <= CYCLE_BUDGET,
        "mean_cycles": int(r.mean_cycles),
        "us_at_16mhz": r.max_cycles / 16.0,
        "worst_case_cycles": int(w.max_cycles),
        "worst_case_us": w.max_cycles / 16.0,
        "worst_case_ok": w.max_cycles <= CYCLE_BUDGET,
        "estimator_ram": int(r.estimator_ram),
    }


def worst_case_blob():
    """The issue's worst case: 3 inputs x 3 outputs, 10 poles in every H1 and H2, 16
    breakpoints in every f and g. Too large for the EEPROM, so it is measured from flash."""

    s = random_structure(np.random.default_rng(1), 3, 3, h1_poles=10, h2_poles=10, breakpoints=16, kind="wh")
    blob, _ = design_blob(s, [(-100.0, 100.0)] * 3, 0.01, 1, [])
    return blob


def heaviest_storable_blob(seed: int = 1) -> bytes:
    """The most expensive model a flash store slot holds (1,016 bytes): the first of
    FLASH_HEAVY_CANDIDATES that fits (3 x 3 WH, 10 + 10 poles, 3 breakpoints: 1,129 bytes)."""

    for h1, h2, bp in FLASH_HEAVY_CANDIDATES:
        s = random_structure(np.random.default_rng(seed), 3, 3, h1_poles=h1, h2_poles=h2, breakpoints=bp, kind="wh")
        try:
            return quantize(s, input_range=(-90.0, 10.0), capacity=FLASH_SLOT_BYTES, noise_lsb=0).blob.to_bytes()
        except Exception:  # too large for a slot: the next candidate
            continue
    raise RuntimeError(f"no candidate model fits a {FLASH_SLOT_BYTES}-byte flash slot")


def store_in_flash(board, dev, blob: bytes) -> None:
    """Upload ``blob`` into the simboard's flash model store (the slot not running) and check
    that it runs."""

    _, info = upload(dev, blob, board.program_flash)
    if not (info.valid and info.store == "flash" and info.length == len(blob)):
        raise RuntimeError(f"the uploaded model does not run: {info}")


def heavy_model_blob(seed: int = 1) -> bytes:
    """The most expensive model that fits the EEPROM model area (776 bytes): 3 inputs x
    3 outputs, Wiener-Hammerstein with 4 poles in every H1 and H2 and 6 breakpoints in every
    f and g, or the next smaller candidate that fits (2 + 2 poles: 733 bytes)."""

    blob = b""
    for h1, h2, bp in ((4, 4, 6), (4, 2, 6), (2, 2, 6)):
        s = random_structure(np.random.default_rng(seed), 3, 3, h1_poles=h1, h2_poles=h2, breakpoints=bp, kind="wh")
        try:
            blob = quantize(s, input_range=(-90.0, 10.0)).blob.to_bytes()
        except Exception:  # too large for the EEPROM: try the next candidate
            continue
        if len(blob) <= MODEL_REGION_BYTES:
            return blob
    raise RuntimeError(f"no candidate model fits {MODEL_REGION_BYTES} bytes (last {len(blob)})")


def simboard_overruns(seconds: float, rate_hz: int = OVERRUN_RATE_HZ) -> dict:
    """Flash the heaviest model that fits, then stream 3 ADC channels + IMU + estimates at
    ``rate_hz`` in the simboard for ``seconds`` of simulated time; overruns, samples the host
    counted lost and free stack (never touched bytes, from STATUS) afterwards."""
    try:
        from porosense.device import Device
        from porosense.simboard import SimBoard
    except ImportError as exc:
        return {"status": "pending", "reason": f"simboard not available ({exc})"}
    try:
        blob = heaviest_storable_blob()
        with SimBoard(ELF) as board, Device.open(board.url, handshake_timeout_s=15.0) as dev:
            store_in_flash(board, dev, blob)
            dev.start_stream(rate_hz, 0x1F)
            n = 0
            flags = 0
            first = last = None
            for s in dev.samples(timeout_s=15.0):  # wall time: the simulation speed varies
                first = s.t_us if first is None else first
                last = s.t_us
                flags |= s.status
                n += 1
                if n >= int(seconds * rate_hz):
                    break
            dev.stop_stream()
            st = dev.status()
        return {
            "status": "measured",
            "rate_hz": rate_hz,
            "seconds": seconds,
            "samples": n,
            "samples_lost": int(dev.stats.samples_lost),
            "model_bytes": len(blob),
            "estimator_on": not (flags & ESTIMATOR_OFF),
            "sample_flags_seen": flags,
            "overruns": int(st.overruns),
            "free_stack": int(st.free_ram),
            "dropped_telemetry": int(st.dropped_telemetry),
            "span_us": int((last - first) % (1 << 32)) if n > 1 else 0,
        }
    except Exception as exc:
        return {"status": "pending", "reason": f"{type(exc).__name__}: {exc}"}


# Channel configurations of the rate search: (name, START_STREAM channel mask).
RATE_CONFIGS = (
    ("1 ADC channel", 0x01),
    ("3 ADC channels", 0x07),
    ("3 ADC + IMU", 0x0F),
    ("3 ADC + IMU + estimator", 0x1F),
)


def advertised_max_rate_hz() -> int:
    """SAMPLE_RATE_HZ maximum of the protocol catalogue: what HELLO-era hosts and the
    firmware (START_STREAM, CONFIG_SET) accept."""

    return int(CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max)


BENCH_BUILD = FIRMWARE_DIR / "build" / "bench"
BENCH_ELF = BENCH_BUILD / "porosense.elf"
BENCH_RATE_LIMIT_HZ = 1000  # the 1 kHz timer tick: the highest rate the sample clock can make


def build_rate_variant() -> subprocess.CompletedProcess:
    """The firmware built with its START_STREAM limit raised to 1000 Hz
    (``-DPOROSENSE_RATE_LIMIT_HZ``), into firmware/build/bench: only for searching the real
    limit above the advertised one. Everything else is the release build."""
    import fcntl

    BENCH_BUILD.mkdir(parents=True, exist_ok=True)
    with open(FIRMWARE_DIR / "build" / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return subprocess.run(
            [
                "make",
                "-s",
                "-C",
                str(FIRMWARE_DIR),
                "BUILD=build/bench",
                f"OPT_EXTRA=-DPOROSENSE_RATE_LIMIT_HZ={BENCH_RATE_LIMIT_HZ}",
            ],
            capture_output=True,
            text=True,
            timeout=900,
        )


def _lost_at(dev, rate_hz: int, mask: int, seconds: float) -> dict:
    """Stream ``seconds`` of samples at ``rate_hz``: skipped ticks (STATUS.overruns), SAMPLE
    frames dropped for a full UART buffer, and samples lost as the host counted them from
    the SAMPLE sequence numbers."""
    st0 = dev.status()
    lost0 = dev.stats.samples_lost
    dev.start_stream(rate_hz, mask)
    n = 0
    for _ in dev.samples(timeout_s=15.0):  # wall time: the simulation speed varies
        n += 1
        if n >= int(seconds * rate_hz):
            break
    dev.stop_stream()
    st = dev.status()
    return {
        "overruns": int(st.overruns - st0.overruns),
        "dropped": int(st.dropped_telemetry - st0.dropped_telemetry),
        "lost": int(dev.stats.samples_lost - lost0),
    }


def _clean(r: dict) -> bool:
    return r["overruns"] == 0 and r["dropped"] == 0


def max_clean_rates(
    probe_s: float = 3.0,
    confirm_s: float = 60.0,
    upper_hz: int = BENCH_RATE_LIMIT_HZ,
    configs=RATE_CONFIGS,
    elf: Path | None = None,
) -> dict:
    """For each channel configuration, the highest whole rate (Hz) at which every sample
    reaches the host: no skipped tick, no SAMPLE dropped. A binary search over
    10 Hz .. ``upper_hz`` with ``probe_s`` of simulated streaming per step, then
    ``confirm_s`` at the rate found (stepping down 1 Hz while it loses samples). The
    estimator runs the heaviest storable model (a flash slot's). Runs the rate variant of the
    firmware (``build_rate_variant``), whose only difference is the START_STREAM limit."""
    try:
        from porosense.device import Device
        from porosense.simboard import SimBoard
    except ImportError as exc:
        return {"status": "pending", "reason": f"simboard not available ({exc})"}
    if elf is None:
        proc = build_rate_variant()
        if proc.returncode != 0:
            return {"status": "pending", "reason": f"rate variant build failed: {proc.stderr[-500:]}"}
        elf = BENCH_ELF
    rows = []
    try:
        blob = heaviest_storable_blob()
        with SimBoard(elf) as board, Device.open(board.url, handshake_timeout_s=15.0) as dev:
            store_in_flash(board, dev, blob)
            for name, mask in configs:
                lo, hi = 10, upper_hz + 1  # lo: clean, hi: losing (or beyond the search)
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if _clean(_lost_at(dev, mid, mask, probe_s)):
                        lo = mid
                    else:
                        hi = mid
                rate = lo
                confirm = _lost_at(dev, rate, mask, confirm_s)
                while not _clean(confirm) and rate > 10:
                    rate -= 1
                    confirm = _lost_at(dev, rate, mask, confirm_s)
                above = _lost_at(dev, rate + 1, mask, probe_s) if rate < upper_hz else None
                rows.append(
                    {
                        "config": name,
                        "channel_mask": mask,
                        "max_clean_hz": rate,
                        "confirm_s": confirm_s,
                        **confirm,
                        "above": above,
                    }
                )
    except Exception as exc:
        return {"status": "pending", "reason": f"{type(exc).__name__}: {exc}"}
    full = [r for r in rows if r["channel_mask"] == 0x1F]
    measured = full[0]["max_clean_hz"] if full else None
    return {
        "status": "measured",
        "advertised_max_hz": advertised_max_rate_hz(),
        "model_bytes": len(blob),
        "probe_s": probe_s,
        "confirm_s": confirm_s,
        "upper_hz": upper_hz,
        "configs": rows,
        "measured_max_hz": measured,
        "advertised_equals_measured": measured == advertised_max_rate_hz(),
    }


class RateMismatch(RuntimeError):
    """The advertised SAMPLE_RATE_HZ maximum is not the measured highest clean rate."""


def run(size: str = "small") -> dict:
    """Build the firmware and report its budgets. ``size="small"`` streams 5 s of simulated
    time in the simboard, ``"full"`` the 60 s the budget quotes."""
    why = toolchain_missing()
    if why:
        return {"status": "skipped", "reason": why, "summary": [f"firmware: skipped ({why})"]}
    if FIRMWARE_DIR is not None:
        proc = build()
        if proc.returncode != 0:
            raise RuntimeError(f"firmware build failed:\n{proc.stdout}\n{proc.stderr}")
    elif not ELF.is_file():
        return {
            "status": "skipped",
            "reason": "no firmware ELF in this installation",
            "summary": ["firmware: skipped (no firmware ELF in this installation)"],
        }
    sz = measure_size()
    seconds = 60.0 if size == "full" else 5.0
    cyc = estimator_cycles()
    sim = simboard_overruns(seconds)
    at_limit = simboard_overruns(seconds, advertised_max_rate_hz())
    full = size == "full"
    rates = max_clean_rates(
        probe_s=3.0 if full else 1.0,
        confirm_s=60.0 if full else 3.0,
        upper_hz=BENCH_RATE_LIMIT_HZ if full else 300,
        configs=RATE_CONFIGS if full else RATE_CONFIGS[1::2],
    )
    result = {
        "elf": str(ELF),
        "size": sz.to_dict(),
        "flash_bytes": sz.flash,
        "flash_budget": FLASH_BUDGET,
        "flash_ok": sz.flash <= FLASH_BUDGET,
        "static_ram_bytes": sz.static_ram,
        "static_ram_budget": RAM_BUDGET,
        "static_ram_ok": sz.static_ram <= RAM_BUDGET,
        "stack_room_bytes": sz.stack_room,
        "estimator_cycles": cyc,
        "cycle_budget": CYCLE_BUDGET,
        "overruns_100hz": sim,
        "at_advertised_max": at_limit,
        "max_clean_rates": rates,
    }
    summary = [
        f"flash: {sz.flash} B of {FLASH_BUDGET} B budget (text {sz.text} + data {sz.data})",
        f"static RAM: {sz.static_ram} B of {RAM_BUDGET} B budget (data {sz.data} + bss {sz.bss})",
        f"stack room: {sz.stack_room} B (2048 - data - bss - noinit)",
    ]
    if cyc.get("status") == "measured":
        summary.append(
            f"estimator step, worst case (3x3, 10 poles per block, 16 breakpoints, "
            f"from flash): {cyc['worst_case_cycles']} cycles (budget {CYCLE_BUDGET})"
        )
        summary.append(
            f"estimator step, heaviest EEPROM model ({cyc['model_bytes']} B): "
            f"{cyc['cycles']} cycles = {cyc['us_at_16mhz']:.0f} us"
        )
        summary.append(
            f"estimator step, heaviest flash-slot model ({cyc['flash_model_bytes']} B, 3x3 WH, from "
            f"flash): {cyc['flash_model_cycles']} cycles (budget {CYCLE_BUDGET}: "
            f"{'within' if cyc['flash_model_ok'] else 'OVER'}; 100 Hz period 160,000), bit-exact "
            f"{cyc['flash_model_bit_exact']}"
        )
    else:
        summary.append(f"estimator step: pending ({cyc.get('reason')})")
    if sim.get("status") == "measured":
        summary.append(
            f"100 Hz, 3 ADC + IMU + estimator ({sim['model_bytes']} B model, "
            f"{'on' if sim['estimator_on'] else 'OFF'}) + telemetry, {seconds:g} s "
            f"simulated: {sim['overruns']} overruns, {sim['samples']} samples, "
            f"free stack {sim['free_stack']} B"
        )
    else:
        summary.append(f"overruns at 100 Hz: pending ({sim.get('reason')})")
    if at_limit.get("status") == "measured":
        summary.append(
            f"advertised maximum {at_limit['rate_hz']} Hz, 3 ADC + IMU + estimator, {seconds:g} s "
            f"simulated (release build): {at_limit['overruns']} overruns, "
            f"{at_limit['samples_lost']} samples lost, {at_limit['samples']} samples"
        )
    if rates.get("status") == "measured":
        for row in rates["configs"]:
            a = row["above"]
            above = (
                (
                    f"; at {row['max_clean_hz'] + 1} Hz: {a['overruns']} skipped ticks, {a['dropped']} "
                    f"dropped, {a['lost']} counted lost by the host in {rates['probe_s']:g} s"
                )
                if a
                else ""
            )
            summary.append(
                f"max clean rate, {row['config']}: {row['max_clean_hz']} Hz (0 lost in "
                f"{row['confirm_s']:g} s simulated){above}"
            )
    else:
        summary.append(f"max clean rates: pending ({rates.get('reason')})")
    if rates.get("status") == "measured" and rates["measured_max_hz"] is not None:
        m, a = rates["measured_max_hz"], rates["advertised_max_hz"]
        verdict = "equal" if m == a else "DIFFERENT"
        summary.append(
            f"every channel + IMU + heaviest storable model ({rates['model_bytes']} B, flash): measured "
            f"{m} Hz clean over {rates['confirm_s']:g} s"
            + ("" if full else " (CI size: the full run confirms over 60 s)")
            + f"; advertised {a} Hz: {verdict}"
        )
        if m != a and full:
            summary.append(
                f"*** set SAMPLE_RATE_HZ max = {m} in protocol/messages.toml and run python protocol/generate.py ***"
            )
    result["summary"] = summary
    result["advertised_equals_measured"] = rates.get("advertised_equals_measured")
    return result
