"""The porosense firmware itself on the simboard: it answers HELLO over the protocol."""

from __future__ import annotations

import time

import pytest
import serial

from porosense.protocol import FrameDecoder, Hello, HelloReply, encode_message
from porosense.simboard import DEFAULT_ELF, SimBoard

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
        assert reply.proto_major == 1 and reply.n_channels == 3
        # uptime is AVR time: it cannot exceed the time the board has run
        assert 0 < reply.uptime_ms <= board.sim_time_s * 1000 + 1
        assert board.counters["twi_nacks"] == 0      # both sensors found at boot


def test_firmware_answers_hello_after_reset(firmware_elf):
    with SimBoard(firmware_elf, actuator="contractor") as board:
        hello(board.url, seq=1)
        board.reset()
        t_reset = board.sim_time_s
        frame = hello(board.url, seq=2)
        assert frame.seq == 2
        assert frame.message().uptime_ms <= (board.sim_time_s - t_reset) * 1000 + 2
