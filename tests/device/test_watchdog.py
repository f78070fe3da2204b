"""Conformance: the host-link watchdog cuts the outputs when the host falls silent."""

from __future__ import annotations

import time

import numpy as np

from porosense.protocol import Result, StatusFlag


def test_silence_trips_the_watchdog(dev):
    trips = dev.status().watchdog_trips
    dev.set_watchdog(200)
    dev.set_outputs(-20.0, pumps=1, valves=1)
    time.sleep(0.35 + 0.25 * dev.timeout_scale)  # a board slower than real time needs longer
    st = dev.status()
    assert st.has(StatusFlag.WATCHDOG_TRIPPED)
    assert not st.has(StatusFlag.OUTPUTS_ACTIVE)
    assert st.watchdog_trips == trips + 1
    errors = [e for e in dev.errors if e.code == Result.BAD_STATE and e.detail == StatusFlag.WATCHDOG_TRIPPED]
    assert len(errors) == 1
    dev.set_outputs(-20.0, pumps=1, valves=1)  # the next SET_OUTPUTS clears the flag
    st = dev.status()
    assert not st.has(StatusFlag.WATCHDOG_TRIPPED) and st.has(StatusFlag.OUTPUTS_ACTIVE)
    dev.set_outputs()


def test_regular_commands_keep_the_outputs_on(dev):
    """Pings well within 500 ms of device time keep a 500 ms watchdog from tripping for 1.5 s."""
    trips = dev.status().watchdog_trips
    dev.set_watchdog(500)
    dev.set_outputs(-20.0, pumps=1, valves=1)
    start = last = dev.ping().device_time_us
    while last - start < 1_500_000:
        now = dev.ping().device_time_us
        assert now - last < 500_000, "the host stalled longer than the watchdog timeout"
        last = now
        time.sleep(0.01)
    st = dev.status()
    assert st.has(StatusFlag.OUTPUTS_ACTIVE) and st.watchdog_trips == trips
    dev.set_outputs()


def test_no_trip_while_outputs_are_off(dev):
    trips = dev.status().watchdog_trips
    dev.set_watchdog(100)
    time.sleep(0.4)
    st = dev.status()
    assert st.watchdog_trips == trips and not st.has(StatusFlag.WATCHDOG_TRIPPED)


def test_trip_shows_in_the_stream_within_the_timeout(dev):
    """Device time is what counts: the trip lands within timeout + 2 periods of the last command."""
    dev.set_watchdog(200)
    dev.set_outputs(-20.0, pumps=1, valves=1)
    dev.start_stream(100, channels=["ADC0"])  # START_STREAM is the last command heard
    samples = []
    for s in dev.samples(100):
        samples.append(s)
        if s.status & StatusFlag.WATCHDOG_TRIPPED:
            break
    dev.stop_stream()
    status = np.array([s.status for s in samples])
    tripped = np.flatnonzero(status & StatusFlag.WATCHDOG_TRIPPED)
    assert tripped.size, "no sample shows the watchdog trip"
    first = samples[tripped[0]]
    # The first sample comes 1..2 periods after START_STREAM.
    elapsed_ms = (first.t_us - samples[0].t_us) / 1000 + 10
    assert 190 <= elapsed_ms <= 240, elapsed_ms
    assert not first.status & StatusFlag.OUTPUTS_ACTIVE
    assert all(s.status & StatusFlag.OUTPUTS_ACTIVE for s in samples[: tripped[0]])
