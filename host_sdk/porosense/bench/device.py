"""``porosense bench device``: how fast the device back-ends run.

* the emulator's streaming rate: SAMPLE frames per second the host receives (lockstep mode,
  as fast as possible, at the highest device rate) and the speed relative to real time that implies;
* PING round trips with the emulator (median, ms);
* the emulated board alone (simulator plant + firmware core, no link): samples per CPU second
  at 200 Hz with three ADC channels, the IMU and a one-output WH model estimating;
* if the simboard and the firmware ELF are available: its speed relative to real time
  (device time of the streamed samples over wall time).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from porosense.device import Device
from porosense.emulator import BoardCore, Emulator
from porosense.firmware.files import elf_path
from porosense.protocol import _messages as m
from porosense.protocol import encode_message
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey
from porosense.quant import quantize
from porosense.sim import make_plant
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

SIZES = {
    "small": {"samples": 4000, "pings": 200, "sim_s": 2.0},
    "full": {"samples": 40000, "pings": 2000, "sim_s": 10.0},
}

RATE_HZ = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max  # the highest rate the firmware accepts


def _stream(dev, n: int, rate_hz: int) -> dict:
    dev.start_stream(rate_hz)
    lost0 = dev.stats.samples_lost
    t0 = time.perf_counter()
    first = last = None
    for _i, s in enumerate(dev.samples(n)):
        if first is None:
            first = s.t_us
        last = s.t_us
    wall = time.perf_counter() - t0
    dev.stop_stream()
    device_s = (last - first) / 1e6
    return {
        "samples": n,
        "lost": dev.stats.samples_lost - lost0,
        "wall_s": wall,
        "device_s": device_s,
        "samples_per_s": n / wall,
        "speed_vs_realtime": device_s / wall,
    }


def emulator_figures(size: str) -> dict:

    cfg = SIZES[size]
    with Emulator(actuator="contractor", seed=0) as emu, Device.open(emu.url) as dev:
        stream = _stream(dev, cfg["samples"], RATE_HZ)
        rtts = [dev.ping().rtt_s for _ in range(cfg["pings"])]
    return stream | {"ping_median_ms": statistics.median(rtts) * 1e3, "pings": cfg["pings"]}


def board_cpu_figures(size: str) -> dict:
    """Samples per CPU second of BoardCore.sample with a model loaded (best of 3 runs)."""

    blob = _one_output_blob()
    n = SIZES[size]["samples"]
    best = 0.0
    for _ in range(3):
        board = BoardCore(make_plant("contractor", seed=0), send=lambda data, t_us=None: None)
        msgs = [m.ModelBegin(length=len(blob), crc=int.from_bytes(blob[-2:], "little"), format_version=blob[2])]
        msgs += [m.ModelChunk(offset=o, data=blob[o : o + 100]) for o in range(0, len(blob), 100)]
        msgs += [m.ModelCommit(), m.StartStream(rate_hz=RATE_HZ, channel_mask=0x1F)]
        for seq, msg in enumerate(msgs):
            board.receive(encode_message(msg, seq + 1))
        t0 = time.process_time()
        for _ in range(n):
            board.sample()
        best = max(best, n / (time.process_time() - t0))
    return {"samples": n, "samples_per_cpu_s": best, "model_bytes": len(blob)}


def _one_output_blob() -> bytes:
    """A one-output WH blob (f, 2nd-order H1, g, 2nd-order H2) from porosense.quant."""
    from scipy import signal

    f = PiecewiseLinear(np.array([-1.0, -0.5, 0.0, 0.5]), np.array([-0.8, -0.45, 0.0, 0.4]))
    g = PiecewiseLinear(np.array([-2.0, -0.5, 0.0, 1.0]), np.array([40.0, 12.0, 0.0, -5.0]))
    chain = OutputChain(
        name="strain_0",
        g=g,
        h2=SOSCascade(signal.zpk2sos([], [0.7, 0.2], 0.24)),
        branches=(Branch(input=0, f=f, h1=SOSCascade(signal.zpk2sos([-0.5], [0.9, 0.5], 0.05))),),
    )
    structure = EstimatorStructure(inputs=("dR_0",), outputs=(chain,), ts=1.0 / RATE_HZ, input_units=("dR/100",))
    return quantize(structure, input_range=(-1.0, 0.5)).blob.to_bytes()


def simboard_figures(size: str) -> dict | None:
    """None when the simboard or the ELF is missing."""
    try:
        from porosense.simboard import SimBoard
    except ImportError:
        return None

    elf = elf_path()
    if not elf.is_file():
        return None

    cfg = SIZES[size]
    with SimBoard(elf=str(elf), actuator="contractor") as board:
        with Device.open(board.url, timeout_scale=5.0) as dev:
            return _stream(dev, int(cfg["sim_s"] * 100), 100)


def run(size: str = "small") -> dict:
    """Figures of the device back-ends (see module docstring)."""
    emu = emulator_figures(size)
    board = board_cpu_figures(size)
    sb = simboard_figures(size)
    summary = [
        f"emulator streaming: {emu['samples_per_s']:.0f} samples/s received "
        f"({emu['samples']} samples at {RATE_HZ} Hz device rate, {emu['lost']} lost), "
        f"{emu['speed_vs_realtime']:.0f}x real time",
        f"emulator PING round trip: {emu['ping_median_ms']:.3f} ms median of {emu['pings']}",
        f"emulated board alone (plant + firmware core, WH model estimating): "
        f"{board['samples_per_cpu_s']:.0f} samples per CPU second",
    ]
    if sb is None:
        summary.append("simboard: not available (the simboard harness or the firmware ELF is missing)")
    else:
        summary.append(
            f"simboard: {sb['speed_vs_realtime']:.2f}x real time streaming at 100 Hz "
            f"({sb['samples']} samples, {sb['lost']} lost)"
        )
    return {"size": size, "emulator": emu, "board": board, "simboard": sb, "summary": summary}
