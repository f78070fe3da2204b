"""The porosense firmware itself on the simboard: it answers HELLO over the protocol."""

from __future__ import annotations

import time

import pytest
import serial

from porosense.protocol import (
    Ack,
    FrameDecoder,
    Hello,
    HelloReply,
    Sample,
    SetOutputs,
    StartStream,
    StopStream,
    encode_message,
)
from porosense.protocol._messages import VERSION_MAJOR
from porosense.simboard import DEFAULT_ELF, ConstantPlant, SimBoard

pytestmark = pytest.mark.simboard


@pytest.fixture(scope="module")
def firmware_elf(simboard_built):
    if not DEFAULT_ELF.is_file():
        pytest.skip(f"{DEFAULT_ELF} not built (make -C firmware)")
    return DEFAULT_ELF


def hello(url: str, seq: int, wall_timeout_s: float = 20.0):
    """Sends HELLO until a reply frame arrives (the firmware may still be booting)."""
    port = serial.serial_for_url(url, timeout=0.2)
    decoder = FrameDecoder()
    deadline = time.monotonic() + wall_timeout_s
    try:
        while time.monotonic() < deadline:
            port.write(encode_message(Hello(), seq=seq))
            for frame in decoder.feed(port.read(256)):
                return frame
    finally:
        port.close()
    raise AssertionError("no reply to HELLO")


def test_firmware_answers_hello(firmware_elf):
    with SimBoard(firmware_elf, actuator="contractor", seed=1) as board:
        frame = hello(board.url, seq=7)
        reply = frame.message()
        assert isinstance(reply, HelloReply) and frame.seq == 7
        assert reply.proto_major == VERSION_MAJOR and reply.n_channels == 3
        # uptime is AVR time: it cannot exceed the time the board has run
        assert 0 < reply.uptime_ms <= board.sim_time_s * 1000 + 1
        assert board.counters["twi_nacks"] == 0  # both sensors found at boot


def test_firmware_answers_hello_after_reset(firmware_elf):
    with SimBoard(firmware_elf, actuator="contractor") as board:
        hello(board.url, seq=1)
        board.reset()
        t_reset = board.sim_time_s
        frame = hello(board.url, seq=2)
        assert frame.seq == 2
        assert frame.message().uptime_ms <= (board.sim_time_s - t_reset) * 1000 + 2


def test_firmware_drives_pins_and_streams_sensor_values(firmware_elf):
    volts, euler = (1.0, 2.5, 4.0), (10.5, -20.25, 30.0)
    with SimBoard(firmware_elf, plant=ConstantPlant(volts, euler)) as board:
        session = hello(board.url, seq=1).message().session  # output commands carry it
        # Short reads: a blocked read lets the (sleeping, fast) firmware run on, and the pins
        # are checked well inside the 1 s host-link watchdog after the ACK.
        port = serial.serial_for_url(board.url, timeout=0.01)
        decoder = FrameDecoder()

        def reply_to(msg, seq):
            port.write(encode_message(msg, seq=seq))
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                for frame in decoder.feed(port.read(256)):
                    if frame.seq == seq and not isinstance(frame.message(), Sample):
                        return frame.message()
            raise AssertionError(f"no reply to {msg}")

        assert isinstance(
            reply_to(
                SetOutputs(setpoint_dkpa=(-400, -200, 0), pump_mask=3, valve_mask=1, session=session, counter=1), 2
            ),
            Ack,
        )
        pins = board.pins
        assert pins.pumps == (True, True, False) and pins.valves == (True, False, False)
        for duty, kpa in zip(pins.regulator_duty, (-40.0, -20.0, 0.0)):
            assert abs(duty - kpa / -80.0 * 255) <= 1, pins.regulator_duty

        assert isinstance(reply_to(StartStream(rate_hz=100, channel_mask=0x0F), 3), Ack)
        frames = []
        deadline = time.monotonic() + 20
        while len(frames) < 60 and time.monotonic() < deadline:
            frames += [f for f in decoder.feed(port.read(4096)) if isinstance(f.message(), Sample)]
        port.write(encode_message(StopStream(), seq=4))
        port.close()
    samples = [f.message() for f in frames]
    assert len(samples) >= 60
    codes = tuple(int(v / 4.096 * 32768) for v in volts)  # PGA +-4.096 V
    assert all(s.adc == codes for s in samples), {s.adc for s in samples}
    assert all(s.euler_16 == tuple(round(a * 16) for a in euler) for s in samples[5:])
    steps = [b.t_us - a.t_us for a, b in zip(samples, samples[1:])]
    assert all(abs(d - 10_000) <= 8 for d in steps), steps  # micros() ticks by 4 us
    assert abs((samples[-1].t_us - samples[0].t_us) / len(steps) - 10_000) <= 1
    assert {(b.seq - a.seq) % 256 for a, b in zip(frames, frames[1:])} == {1}
