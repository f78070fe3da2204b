"""The emulator's ground-truth log lines up with SAMPLE times, across the 32-bit clock wrap."""

from __future__ import annotations

import numpy as np

from porosense.device import Device
from porosense.emulator import Emulator


def test_truth_follows_samples_across_the_clock_wrap():
    # Device clock starts 1 s before its 2^32 us wrap; a vacuum step lands around the wrap.
    with Emulator("contractor", truth_log=True, seed=3, realtime=True, speed=10.0, max_catch_up_s=60.0,
                  clock_offset_us=(1 << 32) - 1_000_000) as emu:
        with Device.open(emu.url) as dev:
            dev.start_stream(rate_hz=50)
            samples = list(dev.samples(40))
            dev.set_outputs(setpoint_kpa=[-40.0, 0, 0], pumps=1, valves=1)
            samples += list(dev.samples(160))
            dev.set_outputs(setpoint_kpa=[0.0, 0, 0], pumps=0, valves=0)
            dev.stop_stream()
    t = np.array([s.t_us for s in samples])
    assert t[0] < (1 << 32) < t[-1]  # the stream crossed the wrap
    measured = np.array([s.dr_centi[0] for s in samples]) / 100.0
    truth = emu.truth(t)["dR_0"] * 1.0
    print(f"dR swing {np.ptp(measured):.1f} %, worst truth-measurement gap {np.max(np.abs(truth - measured)):.2f} %")
    assert np.ptp(measured) > 20.0  # the step happened
    # Misaligned by even one sample, the gap during the step would be several %.
    assert np.max(np.abs(truth - measured)) < 1.0
