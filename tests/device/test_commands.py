"""Conformance: every command's answer and its NAKs, output limits, duplicate handling."""

from __future__ import annotations

import math

import pytest

from porosense.device import NakError
from porosense.protocol import MsgType, Result, StatusFlag
from porosense.protocol import _messages as m
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey


def nak_of(fn, *args, **kwargs) -> NakError:
    with pytest.raises(NakError) as err:
        fn(*args, **kwargs)
    return err.value


def test_set_outputs_sets_and_clears_the_active_flag(dev):
    dev.set_outputs(-20.0, pumps=0b001, valves=0b001)
    assert dev.status().has(StatusFlag.OUTPUTS_ACTIVE)
    dev.set_outputs()
    assert not dev.status().has(StatusFlag.OUTPUTS_ACTIVE)


def test_set_outputs_limits(dev):
    cases = [
        ({"setpoint_kpa": [0.1, 0, 0]}, 0),  # a positive (pressure) setpoint
        ({"setpoint_kpa": [0, 0, -60.1]}, 0),  # beyond MIN_SETPOINT_DKPA (-600 by default)
        ({"pumps": 0b1000}, 1),
        ({"valves": 0x80}, 2),
    ]
    for kwargs, detail in cases:
        err = nak_of(dev.set_outputs, **kwargs)
        assert err.code == Result.OUT_OF_RANGE and err.detail == detail, kwargs
    assert not dev.status().has(StatusFlag.OUTPUTS_ACTIVE), "a refused command changed the outputs"


def test_min_setpoint_follows_the_configuration(dev):
    dev.set_outputs([-60.0, -60.0, -60.0], pumps=0b111, valves=0b111)  # exactly at the limit
    dev.set_outputs()
    dev.config_set("MIN_SETPOINT_DKPA", -300)
    try:
        assert nak_of(dev.set_outputs, -30.1, pumps=1, valves=1).code == Result.OUT_OF_RANGE
        dev.set_outputs(-30.0, pumps=1, valves=1)
        dev.set_outputs()
    finally:
        dev.config_set("MIN_SETPOINT_DKPA", CONFIG_SPECS[ConfigKey.MIN_SETPOINT_DKPA].default)


def test_set_watchdog_limits(dev):
    for ms in (100, 10000):
        dev.set_watchdog(ms)
    for ms in (99, 10001):
        err = nak_of(dev.set_watchdog, ms)
        assert err.code == Result.OUT_OF_RANGE and err.detail == 0, ms


def test_status_counts_received_frames_and_uptime(dev):
    a = dev.status()
    dev.ping()
    dev.ping()
    b = dev.status()
    assert b.rx_frames - a.rx_frames == 3  # two pings and this STATUS
    assert b.tx_frames - a.tx_frames >= 3
    assert b.uptime_ms >= a.uptime_ms
    assert b.free_ram > 0


def test_calibrate_r0_limits(dev):
    for n, mask, detail in [(0, 1, 0), (65, 1, 0), (16, 0, 1), (16, 0x08, 1)]:
        err = nak_of(dev.calibrate_r0, n, mask)
        assert err.code == Result.OUT_OF_RANGE and err.detail == detail, (n, mask)


def test_calibrate_r0_of_channel_0(dev):
    r0 = dev.calibrate_r0(8, 0b001)
    assert len(r0) == 3
    assert 1.0 <= r0[0] <= 100_000.0
    assert dev.config_get("R0_CH0_MOHM") == pytest.approx(r0[0] * 1000, abs=1)
    assert not dev.status().has(StatusFlag.R0_UNCALIBRATED)


def test_calibrate_r0_is_refused_while_streaming(dev):
    dev.start_stream(50)
    assert nak_of(dev.calibrate_r0, 4, 1).code == Result.BUSY
    dev.stop_stream()


def test_set_r0_limits_and_effect_on_dr(dev):
    assert nak_of(dev.set_r0, [1500.0, 0, 0], 0).detail == 0
    for bad in (0.5, 200_000.0, math.nan):
        err = nak_of(dev.set_r0, [bad, 0, 0], 0b001)
        assert err.code == Result.OUT_OF_RANGE and err.detail == 1
    dev.set_r0([1500.0, 0, 0], 0b001)
    assert dev.config_get("R0_CH0_MOHM") == 1_500_000
    dev.start_stream(100, channels=["ADC0"])
    s = next(dev.samples(1))
    dev.stop_stream()
    volts = s.adc[0] * 4.096 / 32768
    r = 1000.0 * volts / (5.0 - volts)
    assert s.dr_centi[0] == pytest.approx((r - 1500.0) / 1500.0 * 10000, abs=2)


def test_replay_refusals(dev):
    dev.erase_model()
    assert nak_of(dev.command, m.Replay(reset=1, dr_centi=(0, 0, 0))).code == Result.NO_MODEL
    dev.start_stream(50)
    assert nak_of(dev.command, m.Replay(reset=1, dr_centi=(0, 0, 0))).code == Result.BUSY
    dev.stop_stream()


def test_replay_of_a_partial_sample_is_a_length_error(dev, blob):
    dev.write_model(blob)
    err = nak_of(dev.command, m.Replay(reset=1, dr_centi=(1, 2, 3, 4)))
    assert err.code == Result.BAD_LENGTH


def test_model_read_limits(dev, blob):
    dev.erase_model()
    assert nak_of(dev.command, m.ModelRead(offset=0, length=16)).code == Result.NO_MODEL
    for n in (0, 113):
        err = nak_of(dev.command, m.ModelRead(offset=0, length=n))
        assert err.code == Result.OUT_OF_RANGE and err.detail == 1


def test_device_to_host_types_are_refused_as_commands(dev):
    frame = dev.exchange_raw(MsgType.ACK, bytes([MsgType.PING]))
    assert frame is not None and frame.type == MsgType.NAK
    nak = frame.message()
    assert nak.acked_type == MsgType.ACK and nak.code == Result.UNKNOWN_TYPE


def test_a_duplicate_is_answered_from_the_cache_not_executed(dev, blob):
    """A retried MODEL_CHUNK would fail (offset no longer contiguous) if it ran twice."""
    dev.erase_model()
    dev.command(m.ModelBegin(length=len(blob), crc=_crc(blob), format_version=blob[2]))
    seq = 0x42
    payload = m.ModelChunk(offset=0, data=blob[:64]).pack()
    replies = [dev.exchange_raw(MsgType.MODEL_CHUNK, payload, seq=seq) for _ in range(2)]
    assert all(r is not None for r in replies)
    assert [r.type for r in replies] == [MsgType.ACK, MsgType.ACK]
    assert replies[0].encode() == replies[1].encode()
    # The same sequence number with another type is a new command.
    assert dev.command(m.ModelInfo(), seq=seq).status == 0
    dev.command(m.ModelChunk(offset=64, data=blob[64:]))
    dev.command(m.ModelCommit())
    assert dev.model_info().valid


def test_reset_acknowledges_then_reboots(dev):
    dev.config_reset()  # a stored configuration counts boots
    boots = dev.status().resets
    dev.set_outputs(-10, pumps=1, valves=1)
    info = dev.reset()
    assert info.streaming is False
    st = dev.status()
    assert st.resets == boots + 1
    assert not st.has(StatusFlag.OUTPUTS_ACTIVE)


def _crc(blob: bytes) -> int:
    from porosense.device.client import blob_crc

    return blob_crc(blob)
