"""``porosense bench device``: how fast the device back-ends run.

* the emulator's streaming rate: SAMPLE frames per second the host receives (lockstep mode,
  as fast as possible, 200 Hz device rate) and the speed relative to real time that implies;
* PING round trips with the emulator (median, ms);
* if the simboard and the firmware ELF are available: its speed relative to real time
  (device time of the streamed samples over wall time).
"""

from __future__ import annotations

import statistics
import time

SIZES = {"small": {"samples": 4000, "pings": 200, "sim_s": 2.0}, "full": {"samples": 40000, "pings": 2000, "sim_s": 10.0}}
RATE_HZ = 200


def _stream(dev, n: int, rate_hz: int) -> dict:
    dev.start_stream(rate_hz)
    lost0 = dev.stats.samples_lost
    t0 = time.perf_counter()
    first = last = None
    for i, s in enumerate(dev.samples(n)):
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
    from porosense.device import Device
    from porosense.emulator import Emulator

    cfg = SIZES[size]
    with Emulator(actuator="contractor", seed=0) as emu, Device.open(emu.url) as dev:
        stream = _stream(dev, cfg["samples"], RATE_HZ)
        rtts = [dev.ping().rtt_s for _ in range(cfg["pings"])]
    return stream | {"ping_median_ms": statistics.median(rtts) * 1e3, "pings": cfg["pings"]}


def simboard_figures(size: str) -> dict | None:
    """None when the simboard or the ELF is missing."""
    try:
        from porosense.simboard import SimBoard
    except ImportError:
        return None
    from porosense.firmware.files import elf_path

    elf = elf_path()
    if not elf.is_file():
        return None
    from porosense.device import Device

    cfg = SIZES[size]
    with SimBoard(elf=str(elf), actuator="contractor") as board:
        with Device.open(board.url, timeout_scale=5.0) as dev:
            return _stream(dev, int(cfg["sim_s"] * 100), 100)


def run(size: str = "small") -> dict:
    """Figures of the device back-ends (see module docstring)."""
    emu = emulator_figures(size)
    sb = simboard_figures(size)
    summary = [
        f"emulator streaming: {emu['samples_per_s']:.0f} samples/s received "
        f"({emu['samples']} samples at {RATE_HZ} Hz device rate, {emu['lost']} lost), "
        f"{emu['speed_vs_realtime']:.0f}x real time",
        f"emulator PING round trip: {emu['ping_median_ms']:.3f} ms median of {emu['pings']}",
    ]
    if sb is None:
        summary.append("simboard: not available (the simboard harness or the firmware ELF is missing)")
    else:
        summary.append(
            f"simboard: {sb['speed_vs_realtime']:.2f}x real time streaming at 100 Hz "
            f"({sb['samples']} samples, {sb['lost']} lost)"
        )
    return {"size": size, "emulator": emu, "simboard": sb, "summary": summary}
