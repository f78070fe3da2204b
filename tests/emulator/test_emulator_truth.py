"""The emulator's ground-truth log lines up with SAMPLE times, also after the 32-bit clock wrap."""

from __future__ import annotations

import time

import numpy as np

from porosense.device import Device
from porosense.emulator import Emulator


def test_truth_follows_samples_after_the_clock_wrap():
    # The device clock starts 2 s before its 2^32 us wrap and has wrapped when the stream starts:
    # SAMPLE times are small again while the emulator's own clock is not.
    with Emulator(
        "contractor",
        truth_log=True,
        seed=3,
        realtime=True,
        speed=10.0,
        max_catch_up_s=60.0,
        clock_offset_us=(1 << 32) - 2_000_000,
    ) as emu:
        with Device.open(emu.url) as dev:
            time.sleep(0.5)  # 5 s of device time
            dev.start_stream(rate_hz=50)
            samples = list(dev.samples(40))
            dev.set_outputs(setpoint_kpa=[-40.0, 0, 0], pumps=1, valves=1)
            samples += list(dev.samples(160))
            dev.set_outputs(setpoint_kpa=[0.0, 0, 0], pumps=0, valves=0)
            dev.stop_stream()
    t = np.array([s.t_us for s in samples])
    assert t[0] < 60_000_000  # the stream started after the wrap
    measured = np.array([s.dr_centi[0] for s in samples]) / 100.0
    truth = emu.truth(t)["dR_0"]
    print(f"dR swing {np.ptp(measured):.1f} %, worst truth-measurement gap {np.max(np.abs(truth - measured)):.2f} %")
    assert np.ptp(measured) > 20.0  # the step happened
    # Misaligned by even one sample, the gap during the step would be several %.
    assert np.max(np.abs(truth - measured)) < 1.0
