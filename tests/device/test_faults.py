"""Fault tests on the emulator: a link that corrupts 1e-3 of the bytes in both directions."""

from __future__ import annotations

import itertools

import pytest

from porosense.device import Device
from porosense.emulator import Emulator, Faults

RATE = 1e-3


def test_a_thousand_commands_complete_and_none_runs_twice():
    faults = Faults(rx_corrupt=RATE, tx_corrupt=RATE, seed=11)
    with Emulator(seed=2, faults=faults) as emu, Device.open(emu.url, seed=3) as dev:
        dev.set_watchdog(10000)
        before = emu.core.stats.executed.copy()
        kinds = itertools.cycle(("ping", "config_set", "config_get", "set_outputs", "status", "model_info"))
        issued = 0
        for i, kind in zip(range(1000), kinds):
            if kind == "ping":
                assert dev.ping(nonce=i).nonce == i
            elif kind == "config_set":
                dev.config_set("PWM_OFFSET", i % 200 - 100)
            elif kind == "config_get":
                assert dev.config_get("PWM_OFFSET") == (i - 1) % 200 - 100
            elif kind == "set_outputs":
                dev.set_outputs(-(i % 50) / 10.0, pumps=i % 2, valves=i % 2)
            elif kind == "status":
                dev.status()
            else:
                assert dev.model_info().status == "none"
            issued += 1
        executed = emu.core.stats.executed - before
        dev.set_outputs()
        assert issued == 1000
        assert sum(executed.values()) == 1000, executed  # each exactly once
        assert executed["PING"] == 167 and executed["CONFIG_SET"] == 167
        link = emu.stats.link
        assert link["rx_corrupted"] > 0 and link["tx_corrupted"] > 0
        assert dev.stats.retries > 0, "the link never lost a command or an answer"
        assert emu.core.stats.duplicates > 0, "no retry reached the board twice"
        st = dev.status()
        assert st.bad_crc + st.bad_length + st.bad_version + st.unknown_type > 0


def test_telemetry_loss_seen_by_the_host_is_what_the_link_destroyed():
    faults = Faults(rx_corrupt=RATE, tx_corrupt=RATE, seed=5)
    with Emulator(seed=4, faults=faults) as emu, Device.open(emu.url, seed=9) as dev:
        lost0 = dev.stats.samples_lost
        dev.start_stream(100)
        samples = list(dev.samples(4000))
        dev.stop_stream()
        samples += dev.drain_samples()
        lost = dev.stats.samples_lost - lost0
        first, last = samples[0].t_us, samples[-1].t_us
        damaged = emu.stats.link["telemetry_damaged"]  # device t_us of every SAMPLE the link destroyed
        # The stream numbers its frames from 0, so losses before the first arrival count too;
        # frames after the last arrival are invisible to any receiver.
        assert lost == sum(t < last for t in damaged)
        assert lost > 50  # about 3.7 % of 38-byte frames at 1e-3 per byte
        # Between first and last arrival, the gaps in the timestamps are the damaged frames.
        t = [s.t_us for s in samples]
        gaps = sum(round((b - a) / 10_000) - 1 for a, b in zip(t, t[1:]))
        assert gaps == sum(first < d < last for d in damaged)
        assert sum(v for k, v in dev.decoder_counters.items() if k != "frames") > 0


@pytest.mark.parametrize("direction", ["rx_drop", "tx_drop"])
def test_dropped_bytes_are_survived(direction):
    faults = Faults(seed=8, **{direction: 2e-3})
    with Emulator(seed=2, faults=faults) as emu, Device.open(emu.url, seed=1) as dev:
        for i in range(300):
            assert dev.ping(nonce=i).nonce == i
        assert emu.core.stats.executed["PING"] == 300
        assert emu.stats.link[direction.replace("_drop", "_dropped")] > 0
