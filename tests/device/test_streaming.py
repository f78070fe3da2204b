"""Conformance: SAMPLE telemetry at 50 and 100 Hz, timestamps, loss counting, channel masks."""

from __future__ import annotations

import numpy as np
import pytest

from porosense.device import NakError
from porosense.protocol import Result, StatusFlag
from porosense.protocol._messages import CONFIG_SPECS, Channel, ConfigKey

MAX_RATE_HZ = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max  # the advertised highest rate

SECONDS = 2.0


@pytest.mark.parametrize("rate_hz", [50, 100])
def test_stream_spacing_is_one_period_and_nothing_is_lost(dev, rate_hz):
    lost0 = dev.stats.samples_lost
    dev.start_stream(rate_hz)
    samples = list(dev.samples(int(rate_hz * SECONDS)))
    dev.stop_stream()
    t = np.array([s.t_us for s in samples], dtype=np.int64)
    period_us = 1e6 / rate_hz
    spacing = np.diff(t)
    assert np.all(np.abs(spacing - period_us) <= max(50.0, 0.01 * period_us)), spacing[:20]
    seqs = np.array([s.seq for s in samples])
    assert np.all(np.diff(seqs) % 256 == 1)
    assert dev.stats.samples_lost - lost0 == 0
    assert (t[-1] - t[0]) == pytest.approx((len(t) - 1) * period_us, rel=1e-3)


def test_status_of_a_sample_matches_the_device_state(dev):
    dev.start_stream(100)
    s = next(dev.samples(1))
    dev.stop_stream()
    assert s.channel_mask == 0x1F
    assert s.status & StatusFlag.OUTPUTS_ACTIVE == 0
    assert s.status & StatusFlag.WATCHDOG_TRIPPED == 0


def test_channels_outside_the_mask_are_zero(dev):
    dev.start_stream(100, channels=["ADC0"])
    samples = list(dev.samples(20))
    dev.stop_stream()
    for s in samples:
        assert s.channel_mask == Channel.ADC0
        assert s.adc[1:] == (0, 0) and s.dr_centi[1:] == (0, 0)
        assert s.euler_16 == (0, 0, 0) and s.estimate == (0, 0, 0)
    assert any(s.adc[0] != 0 for s in samples)


def test_no_samples_after_stop(dev):
    dev.start_stream(MAX_RATE_HZ)
    list(dev.samples(10))
    dev.stop_stream()
    received = dev.stats.samples
    dev.ping()
    dev.ping()
    assert dev.stats.samples == received
    assert dev.hello().streaming is False


def test_hello_reports_streaming(dev):
    dev.start_stream(50)
    list(dev.samples(2))
    assert dev.hello().streaming is True
    dev.stop_stream()


def test_rate_outside_limits_is_refused(dev):
    for rate_hz in (9, MAX_RATE_HZ + 1, 200, 0):
        with pytest.raises(NakError) as err:
            dev.start_stream(rate_hz)
        assert err.value.code == Result.OUT_OF_RANGE and err.value.detail == 0, rate_hz
    assert dev.hello().streaming is False


def test_unknown_channel_bits_are_refused(dev):
    with pytest.raises(NakError) as err:
        dev.start_stream(50, channels=0x20)
    assert err.value.code == Result.OUT_OF_RANGE and err.value.detail == 1


def test_stream_limits_are_accepted(dev):
    """10 Hz and the advertised maximum are accepted; samples fall on the 1 kHz tick, one
    sample period apart (rates that do not divide 1000 alternate the two nearest whole ms)."""
    for rate in (10, MAX_RATE_HZ):
        dev.start_stream(rate)
        samples = list(dev.samples(5))
        dev.stop_stream()
        periods_ms = np.diff([s.t_us for s in samples]) / 1000.0
        assert np.all(np.abs(periods_ms - np.round(periods_ms)) <= 0.01), periods_ms
        assert set(np.round(periods_ms).astype(int)) <= {1000 // rate, -(-1000 // rate)}, periods_ms
