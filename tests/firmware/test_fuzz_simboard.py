"""Fuzz the real firmware's command handlers in the simboard (issue 19): 10,000 random frames
of every host-to-device type with random payloads (valid lengths, sessions and model write
offsets most of the time, so that the handlers run rather than refuse). Invariants: every
frame is answered (the host may retry with the same sequence number, as it does), by an
ACK/NAK naming its type or by the type's reply; the outputs stay within their limits; the
firmware never resets by itself; and the link watchdog still cuts the outputs within
WATCHDOG_MS + 50 ms, checked every 2,500 frames."""

from __future__ import annotations

import random

import pytest
from test_firmware_simboard import _open, elf  # noqa: F401  (the built ELF fixture)
from test_safety_simboard import MARGIN_S, _burst, _cut_after, _on_now

from porosense.protocol import MsgType, Result
from porosense.protocol import _messages as m

pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]

FRAMES = int(__import__("os").environ.get("POROSENSE_FUZZ_FRAMES", "10000"))
CHECK_EVERY = 2_500
WATCHDOG_MS = 150
MAX_RESETS = 3  # RESET reboots the board (~0.1 s): a few are enough to cover it

H2D = sorted(t for t, cls in m.MESSAGES.items() if cls.DIRECTION == "h2d")
REPLY_OF = {t: MsgType[cls.REPLY] for t, cls in m.MESSAGES.items() if cls.DIRECTION == "h2d"}


def _payload(rng: random.Random, mtype: int, dev, state: dict) -> bytes:
    cls = m.MESSAGES[mtype]
    n = rng.randint(cls.MIN_LEN, cls.MAX_LEN)
    p = bytearray(rng.getrandbits(8) for _ in range(n))
    structured = rng.random() < 0.7
    if mtype == MsgType.SET_OUTPUTS and structured:
        sp = tuple(0 if rng.random() < 0.3 else rng.randint(-850, 20) for _ in range(3))
        state["counter"] = (state["counter"] + 1) & 0xFFFF
        p = bytearray(
            m.SetOutputs(
                setpoint_dkpa=sp,
                pump_mask=rng.randrange(9),
                valve_mask=rng.randrange(9),
                session=state["session"],
                counter=state["counter"],
            ).pack()
        )
    elif mtype == MsgType.CONFIG_SET:
        key = rng.randrange(20)
        spec = m.CONFIG_SPECS.get(key) if key in m.ConfigKey._value2member_map_ else None
        value = int.from_bytes(p[1:5], "little", signed=True)
        if spec is not None and structured:
            value = rng.randint(spec.min, spec.max)
        if key == m.ConfigKey.ADC_RATE:
            value = rng.choice((6, 7))  # slower rates make a calibration take seconds of AVR time
        p = bytearray(m.ConfigSet(key=key, value=value).pack())
    elif mtype == MsgType.MODEL_CHUNK and structured:
        p[0:2] = state["offset"].to_bytes(2, "little")
    elif mtype == MsgType.START_STREAM and structured:
        p = bytearray(m.StartStream(rate_hz=rng.randint(10, 140), channel_mask=rng.randrange(32)).pack())
    elif mtype == MsgType.SET_WATCHDOG and structured:
        p = bytearray(m.SetWatchdog(timeout_ms=rng.randint(90, 1200)).pack())
    elif mtype == MsgType.MODEL_BEGIN and structured:
        p[0:2] = rng.randrange(1100).to_bytes(2, "little")
    return bytes(p)


def _exchange(dev, mtype: int, payload: bytes, seq: int):
    for attempt in range(4):  # the host's retries: same bytes, same sequence number
        frame = dev.exchange_raw(mtype, payload, seq=seq, timeout_s=3.0)
        if frame is not None:
            return frame, attempt
    return None, 4


def _watchdog_holds(board, dev) -> float:
    dev.hello()
    dev.set_outputs()  # a host would start from off; also ends a write in progress
    dev.set_watchdog(WATCHDOG_MS)
    # Setpoint 0: the fuzzed MIN_SETPOINT_DKPA may refuse any vacuum; pumps and valves count.
    t_last, (on, _) = _burst(board, dev, [_on_now(dev, setpoint_dkpa=0), m.Ping(nonce=1)])
    assert on is not None and on.type == MsgType.ACK, on and on.message()
    return _cut_after(board, t_last)


@pytest.mark.slow
def test_fuzz_commands_on_the_simboard(elf) -> None:
    rng = random.Random(19)
    board, dev = _open(elf, truth_every_ms=1.0, max_speed=None)  # as fast as simavr runs
    board_resets0 = board.counters["resets"]
    state = {"session": dev._session, "counter": 0, "offset": 0}
    counts = {"ack": 0, "nak": 0, "reply": 0, "retried": 0, "resets": 0}
    cuts = []
    try:
        dev.config_set("ADC_RATE", 7)
        for i in range(FRAMES):
            mtype = rng.choice(H2D)
            if mtype == MsgType.RESET and counts["resets"] >= MAX_RESETS:
                mtype = MsgType.PING
            payload = _payload(rng, mtype, dev, state)
            seq = dev._next_seq()
            frame, attempts = _exchange(dev, mtype, payload, seq)
            assert frame is not None, f"frame {i}: {MsgType(mtype).name} {payload.hex()} unanswered"
            counts["retried"] += attempts > 0
            if frame.type in (MsgType.ACK, MsgType.NAK):
                reply = frame.message()
                assert reply.acked_type == mtype, f"frame {i}: {reply} answers {MsgType(mtype).name}"
                counts["ack" if frame.type == MsgType.ACK else "nak"] += 1
                if frame.type == MsgType.ACK and mtype == MsgType.MODEL_BEGIN:
                    state["offset"] = 0
                if frame.type == MsgType.ACK and mtype == MsgType.MODEL_CHUNK:
                    state["offset"] += len(payload) - 2
            else:
                assert frame.type == REPLY_OF[mtype], f"frame {i}: {MsgType(mtype).name} answered by {frame.type}"
                counts["reply"] += 1
                if mtype == MsgType.HELLO:
                    state["session"], state["counter"] = frame.message().session, 0
            if mtype == MsgType.RESET and frame.type == MsgType.ACK:
                counts["resets"] += 1
                dev.hello(wait_s=15.0)
                state["session"], state["counter"] = dev._session, 0
            pins = board.pins
            assert all(-80.0 <= s <= 0.0 for s in pins.setpoint_kpa), pins
            if (i + 1) % CHECK_EVERY == 0:
                cuts.append(_watchdog_holds(board, dev))
                state["session"], state["counter"] = dev._session, dev._out_counter
        st = dev.status()
        print(
            f"{FRAMES} frames: {counts}; watchdog cuts after {[round(c * 1000, 1) for c in cuts]} ms "
            f"(timeout {WATCHDOG_MS} ms); STATUS: {st.rx_frames} frames received, "
            f"{st.watchdog_trips} watchdog trips, {st.overruns} overruns, free stack {st.free_ram} B"
        )
        assert counts["ack"] > FRAMES // 10 and counts["nak"] > FRAMES // 10
        assert board.counters["resets"] - board_resets0 == counts["resets"]  # no reset of its own
        assert len(cuts) == FRAMES // CHECK_EVERY
        assert all(c <= WATCHDOG_MS / 1000 + MARGIN_S for c in cuts)
        assert st.free_ram > 0
    finally:
        dev.close()
        board.close()


def test_fuzz_result_codes_are_known() -> None:
    """Result codes the fuzz test may meet are the catalogue's (a guard for the test itself)."""
    assert {Result.BUSY, Result.BAD_STATE, Result.OUT_OF_RANGE} <= set(Result)
