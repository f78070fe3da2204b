"""Strain control through the Device API on every back-end (emulator; simboard when built):
gains round trip, NAKs, trajectory storage, and the safety cases (host loss, sensor fault,
target beyond the stroke) with the outputs checked against MIN_SETPOINT_DKPA."""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_samples import controlled_samples

from porosense.device import ControlGains, NakError
from porosense.errors import InputError
from porosense.protocol import Result, StatusFlag
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

GAINS = ControlGains(kp_kpa=2.0, ki_kpa_per_s=1.0, slew_per_s=50.0)


def _run(dev, n, ping_every=20, ping=True, limit=5000):
    return controlled_samples(dev, n, limit=limit, ping_every=ping_every, ping=ping)


def test_gains_round_trip_within_one_quantisation_step(dev, blob):
    dev.write_model(blob)
    dev.set_control_gains(GAINS)
    got = dev.control_gains()
    scale = dev.model_info().out_scale[0]
    rate = dev.sample_rate_hz()
    # One LSB of each fixed-point format, in output units.
    assert abs(got[0].kp_kpa - GAINS.kp_kpa) <= 0.5 / (10 * scale * 65536)
    assert abs(got[0].ki_kpa_per_s - GAINS.ki_kpa_per_s) <= 0.5 / (10 * scale / rate * 2**22)
    assert abs(got[0].slew_per_s - GAINS.slew_per_s) <= 0.5 * scale * rate / 16


def test_start_needs_stream_and_refuses_targets_beyond_the_model_range(dev, blob):
    dev.write_model(blob)
    dev.set_control_gains(GAINS)
    with pytest.raises(NakError) as e:
        dev.start_control(0.0)
    assert e.value.code == Result.BAD_STATE
    dev.start_stream(50, 0x11)
    scale = dev.model_info().out_scale[0]
    with pytest.raises(NakError) as e:
        dev.start_control(30001 * scale)
    assert e.value.code == Result.OUT_OF_RANGE and e.value.detail == 2
    with pytest.raises(NakError) as e:
        dev.start_control(0.0, channels=0b010)  # a 1-output model has no channel 1
    assert e.value.code == Result.OUT_OF_RANGE and e.value.detail == 1
    dev.stop_stream()


def test_no_model_is_refused(dev):
    dev.erase_model()
    dev.start_stream(50, 0x11)
    with pytest.raises(NakError) as e:
        dev.start_control(1.0)
    assert e.value.code == Result.NO_MODEL
    dev.stop_stream()


def test_bad_gains_and_trajectories_are_refused_on_the_host(dev, blob):
    with pytest.raises(InputError):
        ControlGains(-1.0, 0.0, 1.0)
    with pytest.raises(InputError):
        ControlGains(1.0, 0.0, 0.0)
    dev.write_model(blob)
    with pytest.raises(InputError):
        dev.write_trajectory([0.5, 1.0], [0.0, 0.0])  # does not start at 0
    with pytest.raises(InputError):
        dev.write_trajectory(np.arange(20) * 0.1, np.zeros(20))  # more than the slot holds


def test_trajectory_targets_follow_the_stored_points(dev, blob):
    dev.write_model(blob)
    scale = dev.model_info().out_scale[0]
    dev.write_trajectory([0.0, 1.0, 2.0], [0.0, -2000 * scale, -2000 * scale])
    dev.set_watchdog(5000)
    dev.start_stream(50, 0x11)
    dev.set_control_gains(ControlGains(0.0, 0.0, 1e4 * scale))  # a fast slew: targets as stored
    dev.start_trajectory()
    samples = [s for s in _run(dev, 150) if s.status & StatusFlag.CONTROL_ACTIVE]
    dev.stop_control()
    dev.stop_stream()
    assert len(samples) > 50
    t = np.array([s.t_us for s in samples]) * 1e-6
    tgt = np.array([s.target[0] for s in samples]) / scale
    # The ramp: -2000 LSB/s between 0 and 1 s after the start; the start is within one sample
    # of the first controlled sample, the target within rounding plus one sample of slope.
    t0 = t[0]
    expect = np.clip(-2000 * (t - t0), -2000, 0)
    assert np.max(np.abs(tgt - expect)) <= 2000 * 0.02 + 2
    assert all(s.command_kpa[0] >= dev.config_get("MIN_SETPOINT_DKPA") / 10 for s in samples)


def test_host_loss_vents_within_the_watchdog(dev, blob):
    dev.write_model(blob)
    dev.set_watchdog(300)
    dev.start_stream(100, 0x11)
    dev.set_control_gains(GAINS)
    dev.start_control(0.0)
    samples = _run(dev, 100, ping=False)  # no command: the host is gone
    dev.stop_stream()
    active = [s for s in samples if s.status & StatusFlag.CONTROL_ACTIVE]
    after = [s for s in samples if s.status & StatusFlag.CONTROL_ABORTED]
    assert active and after
    # CONTROL_START (the last command) ran after the sample before the first controlled one, so
    # the silence is at most this span plus one sample period (10 ms): an upper bound.
    assert (after[0].t_us - active[0].t_us) / 1000 + 10 <= 300 + 50
    assert all(s.status & StatusFlag.WATCHDOG_TRIPPED for s in after)
    assert not any(s.status & StatusFlag.OUTPUTS_ACTIVE for s in after)
    assert all(math.isnan(s.target[0]) for s in after)


def test_autostart_controls_after_reset_and_a_new_host_reads_its_targets(dev, blob):
    dev.write_model(blob)
    scale = dev.model_info().out_scale[0]
    rate = dev.sample_rate_hz()
    dev.write_trajectory([0.0, 1.0], [500 * scale, 500 * scale])
    dev.set_control_gains(GAINS, save=True)  # at SAMPLE_RATE_HZ: the rate autostart streams at
    dev.config_set("AUTOSTART", 2)
    # The longest watchdog the board takes (10 s of board time, 2 s of wall time on a simulated
    # board at 5x): the pings below come every 10 samples, and a loaded host computer can stall
    # the reader longer than the default 1 s of board time (0.2 s of wall time there).
    dev.config_set("WATCHDOG_MS", CONFIG_SPECS[ConfigKey.WATCHDOG_MS].max)
    dev.config_save()
    try:
        dev.reset()
        # The reset's handshake makes this host the board's keeper (the link watchdog guards the
        # outputs from then on): a live host keeps pinging.
        samples = []
        for k, s in enumerate(dev.samples(2 * rate, timeout_s=20)):
            samples.append(s)
            if k % 10 == 9:
                dev.ping()
        st = dev.status()
    finally:
        dev.stop_control()
        dev.stop_stream()
        dev.config_set("AUTOSTART", 0)
        dev.config_set("WATCHDOG_MS", CONFIG_SPECS[ConfigKey.WATCHDOG_MS].default)
        dev.config_save()
    on = [s for s in samples if s.status & StatusFlag.CONTROL_ACTIVE]
    assert on and all(s.status & StatusFlag.STANDALONE for s in on)
    # The host learnt the model's scale by itself: targets in output units.
    assert abs(on[-1].target[0] - 500 * scale) <= scale
    assert not st.flags & StatusFlag.WATCHDOG_TRIPPED  # the host kept the link alive
