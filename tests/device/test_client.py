"""The Device client on its own: opening, timeouts, stale answers, argument forms, ports."""

from __future__ import annotations

import pytest

from porosense.device import Device, NakError
from porosense.device.ports import PortInfo, classify, list_ports
from porosense.emulator import Emulator
from porosense.errors import DeviceError
from porosense.protocol import MsgType, Result, encode_message
from porosense.protocol import _messages as m


def test_nothing_answering_is_a_clear_error():
    with pytest.raises(DeviceError, match="no answer to HELLO from loop://"):
        Device.open("loop://", handshake_timeout_s=0.5)


def test_unopenable_port_is_a_clear_error():
    with pytest.raises(DeviceError, match="cannot open /dev/porosense-no-such-port"):
        Device.open("/dev/porosense-no-such-port")


def test_stale_and_foreign_answers_are_ignored():
    """On loop:// the host reads back its own PING (a foreign type) and pre-queued answers."""
    dev = Device.open("loop://", handshake=False, seed=1)
    try:
        seq = (dev._seq + 1) & 0xFF
        stale = encode_message(m.Pong(nonce=5, device_time_us=1), seq=(seq - 1) & 0xFF)
        wrong_nonce_type = encode_message(m.Ack(acked_type=MsgType.PING), seq=seq)
        good = encode_message(m.Pong(nonce=5, device_time_us=123), seq=seq)
        dev.send_raw(stale + wrong_nonce_type + good)
        assert dev.ping(nonce=5).device_time_us == 123
        assert dev.stats.stale_replies == 2
        assert dev.stats.retries == 0
    finally:
        dev.close()


def test_nak_error_names_command_and_code():
    err = NakError(MsgType.SET_OUTPUTS, Result.OUT_OF_RANGE, 1)
    assert err.code == Result.OUT_OF_RANGE and err.detail == 1
    assert "SET_OUTPUTS" in str(err) and "OUT_OF_RANGE" in str(err)


def test_argument_forms_reach_the_board():
    with Emulator() as emu, Device.open(emu.url) as dev:
        dev.set_outputs(-12.34, pumps=[True, False, True], valves=0b010)
        assert emu.core.outputs == ([-123, -123, -123], 0b101, 0b010)
        dev.set_outputs([-5, -7.5])
        assert emu.core.outputs[0] == [-50, -75, 0]
        with pytest.raises(ValueError, match="unknown stream channel"):
            dev.start_stream(50, channels=["ADC7"])
        with pytest.raises(ValueError, match="unknown configuration key"):
            dev.config_get("NO_SUCH_KEY")


def test_closing_stops_the_stream_and_the_outputs():
    with Emulator() as emu:
        with Device.open(emu.url) as dev:
            dev.set_outputs(-20, pumps=1, valves=1)
            dev.start_stream(50)
            list(dev.samples(3))
        assert not emu.core.streaming and emu.core.outputs == ([0, 0, 0], 0, 0)


def test_uno_usb_ids_are_recognised():
    assert classify(0x2341, 0x0043) == "Arduino Uno R3"
    assert classify(0x1A86, 0x7523) == "Uno clone (CH340)"
    assert classify(0x0403, 0x6001).startswith("Uno clone")
    assert classify(0x2341, 0x8036) is None and classify(None, None) is None
    p = PortInfo("/dev/ttyACM0", "Arduino Uno", 0x2341, 0x0043, "123", classify(0x2341, 0x0043))
    assert p.likely_uno and "2341:0043" in str(p) and p.to_dict()["likely_uno"]


def test_list_ports_puts_likely_unos_first():
    ports = list_ports()
    flags = [p.likely_uno for p in ports]
    assert flags == sorted(flags, reverse=True)


def test_sample_block_to_recording():
    with Emulator(actuator="3dof") as emu, Device.open(emu.url) as dev:
        dev.start_stream(100)
        block = dev.read_samples(50)
        dev.stop_stream()
    rec = block.to_recording(n_channels=3, imu=True, outputs=("theta_x",), out_scale=(0.01,))
    assert rec.t[0] == 0.0 and abs(rec.t[-1] - 0.49) < 1e-9
    assert {"adc_0", "dR_2", "theta_x", "theta_y", "est_theta_x", "t_dev_us"} <= set(rec.names)
    assert rec.units["dR_0"] == "%" and rec.meta["samples_lost"] == 0
    assert abs(rec["dR_1"][0] - block.dr_centi[0, 1] / 100.0) < 1e-12
