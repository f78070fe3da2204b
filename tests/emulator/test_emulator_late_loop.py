"""A late emulator loop changes nothing the board does: the ticks it missed are made at their own
times, with the plant following the controller's outputs tick by tick.

The closed loop changes the regulator's setpoint at every tick, so a plant that jumped to the
wall clock's "now" with the first late tick's outputs (and read the same state for the ticks
after it) would act like a loop delay: on a busy host computer the emulated closed loop
oscillated. Here the same board runs twice: once called every sample period, once only every
``LATE_S`` (a host computer that wakes the emulator late), with host frames at the same device
times. The truth (the plant's strain at every tick) must agree sample for sample.
"""

from __future__ import annotations

import numpy as np

from porosense.bench.device import _one_output_blob
from porosense.device import control
from porosense.emulator import BoardCore
from porosense.protocol import FrameDecoder, encode_message
from porosense.protocol import _messages as m
from porosense.sim import make_plant

RATE_HZ = 50
PING_EVERY_US = 100_000  # host frames, at the same device times in both runs (link watchdog 200 ms)
LATE_S = 0.1  # the late run's loop wakes every 5 sample periods
RUN_S = 6.0


class _Board:
    """A BoardCore driven like the emulator's real-time loop, with the replies decoded."""

    def __init__(self):
        self.decoder, self.replies = FrameDecoder(), []
        self.core = BoardCore(make_plant("contractor", seed=4), send=self._on_send)
        self.core.truth_log = {}
        self.seq = 0

    def _on_send(self, data: bytes, sample_t_us=None) -> None:
        self.replies += [f.message() for f in self.decoder.feed(data)]

    def command(self, msg):
        self.seq += 1
        self.core.receive(encode_message(msg, self.seq))
        acks = [r for r in self.replies if isinstance(r, (m.Ack, m.Nak))]
        return acks[-1] if acks else None


def _closed_loop(step_us: int) -> dict:
    board = _Board()
    blob = _one_output_blob()
    board.command(m.ModelBegin(length=len(blob), crc=int.from_bytes(blob[-2:], "little"), format_version=blob[2]))
    for o in range(0, len(blob), 100):
        board.command(m.ModelChunk(offset=o, data=blob[o : o + 100]))
    board.command(m.ModelCommit())
    board.command(m.Hello())
    hello = [r for r in board.replies if isinstance(r, m.HelloReply)][-1]
    session, crc = hello.session, hello.model_crc
    fixed = control.to_fixed(control.ControlGains(kp_kpa=1.0, ki_kpa_per_s=3.0, slew_per_s=20.0), [0.01], RATE_HZ)
    assert isinstance(board.command(m.ControlGains(**fixed, model_crc=crc, rate_hz=RATE_HZ)), m.Ack)
    assert isinstance(board.command(m.StartStream(rate_hz=RATE_HZ, channel_mask=0x1F)), m.Ack)
    reply = board.command(m.ControlStart(mode=0, channel_mask=1, target=(600, 0, 0), session=session, counter=1))
    assert isinstance(reply, m.Ack), reply
    core = board.core
    t0 = core.T_us
    setpoints = []
    for k in range(1, int(RUN_S * 1e6 / step_us) + 1):
        core.run_until(t0 + k * step_us)
        setpoints.append(core.outputs[0][0])
        if (k * step_us) % PING_EVERY_US == 0:
            board.command(m.Ping(nonce=k & 0xFFFF))
    assert core.fw.state.streaming
    log = core.truth_log
    return {"t_us": np.array(log["t_us"]), "strain": np.array(log["strain_0"]), "setpoints": setpoints}


def test_a_late_loop_makes_the_same_closed_loop_as_one_on_time():
    on_time = _closed_loop(1_000_000 // RATE_HZ)
    late = _closed_loop(int(LATE_S * 1e6))
    n = min(len(on_time["t_us"]), len(late["t_us"]))
    # Every tick was made, at its own time, in both runs.
    assert n >= RUN_S * RATE_HZ - 2
    assert np.array_equal(on_time["t_us"][:n], late["t_us"][:n])
    # The controller moved the setpoint during the run (otherwise nothing is tested).
    assert len(set(on_time["setpoints"])) > 10
    gap = float(np.max(np.abs(on_time["strain"][:n] - late["strain"][:n])))
    print(
        f"{n} ticks, strain {np.min(on_time['strain']):.2f}..{np.max(on_time['strain']):.2f} %, "
        f"largest gap late vs on time {gap:.2e} % strain"
    )
    assert gap <= 1e-9
