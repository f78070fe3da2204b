"""Fault tests on the emulator: a link that corrupts 1e-3 of the bytes in both directions.

"Executed exactly once" is observed on the firmware itself: REPLAY without reset advances the
estimator's state, so a REPLAY run twice would shift every later estimate away from the
independent Python reference; the firmware's STATUS.rx_frames counts every frame it
received, retries included.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from models import make_blob, reference_run

from porosense.device import Device
from porosense.emulator import Emulator, Faults

RATE = 1e-3


def _replay_inputs(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.cumsum(rng.normal(0, 300, size=(n, 3)), axis=0), -9000, 4000).astype(np.int16)


def test_a_thousand_commands_complete_and_none_runs_twice():
    faults = Faults(rx_corrupt=RATE, tx_corrupt=RATE, seed=11)
    blob = make_blob(1)
    x = _replay_inputs(167 * 4, seed=12)
    with Emulator(seed=2, faults=faults) as emu, Device.open(emu.url, seed=3) as dev:
        dev.set_watchdog(10000)
        dev.write_model(blob)
        rx0 = dev.status().rx_frames
        kinds = itertools.cycle(("replay", "config_set", "config_get", "set_outputs", "status", "model_info"))
        issued, est, k = 0, [], 0
        for i, kind in zip(range(1000), kinds):
            if kind == "replay":
                est.append(dev.replay(x[k : k + 4], reset=(k == 0)))
                k += 4
            elif kind == "config_set":
                dev.config_set("PWM_OFFSET", i % 200 - 100)
            elif kind == "config_get":
                assert dev.config_get("PWM_OFFSET") == (i - 1) % 200 - 100
            elif kind == "set_outputs":
                dev.set_outputs(-(i % 50) / 10.0, pumps=i % 2, valves=i % 2)
            elif kind == "status":
                dev.status()
            else:
                assert dev.model_info().valid
            issued += 1
        received = dev.status().rx_frames - rx0  # the 1000 commands and their retries that arrived
        dev.set_outputs()
        assert issued == 1000 and k == len(x)
        # Any REPLAY executed twice would have moved the estimator on by 4 extra samples.
        assert np.array_equal(np.vstack(est), reference_run(blob, x))
        link = emu.stats.link
        assert link["rx_corrupted"] > 0 and link["tx_corrupted"] > 0
        assert dev.stats.retries > 0, "the link never lost a command or an answer"
        assert received > 1000, "no retry reached the board twice"
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
    blob = make_blob(1)
    x = _replay_inputs(300 * 2, seed=13)
    with Emulator(seed=2, faults=faults) as emu, Device.open(emu.url, seed=1) as dev:
        dev.write_model(blob)
        est = [dev.replay(x[2 * i : 2 * i + 2], reset=(i == 0)) for i in range(300)]
        for i in range(300):
            assert dev.ping(nonce=i).nonce == i
        # Each of the 300 REPLAYs ran once: the estimates continue the reference's state.
        assert np.array_equal(np.vstack(est), reference_run(blob, x))
        assert emu.stats.link[direction.replace("_drop", "_dropped")] > 0
