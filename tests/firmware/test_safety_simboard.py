"""Safety of the real firmware in the simboard (issue 19): the host-link watchdog cuts the
outputs within WATCHDOG_MS + 50 ms of the last host command whatever the board is doing
(a slow R0 calibration, a model flash, streaming at the highest rate, its own frames echoed
back); a skipped sample tick reaches the host as a lost sample; a replayed old SET_OUTPUTS
cannot turn the pumps back on.

Times are AVR times from the plant's per-tick pin log. The silence is measured from the AVR
time just before the host sent its last frame, so it is an upper bound of the true one."""

from __future__ import annotations

import threading

import pytest
from test_firmware_simboard import _open, elf  # noqa: F401  (the built ELF fixture)

from porosense.bench import firmware as fw
from porosense.protocol import MsgType, Result, encode_message
from porosense.protocol import _messages as m

pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]

WATCHDOG_MS = 200
MARGIN_S = 0.050  # the bound: outputs off within the timeout + 50 ms


def _any_on(row) -> bool:
    return any(row[f"pump_{i}"] or row[f"valve_{i}"] or row[f"p_cmd_{i}"] < 0 for i in range(3))


def _burst(board, dev, messages, timeout_s: float = 5.0):
    """Sends the command ``messages`` back to back in one write (a busy host cannot stall
    between them), then reads their answers. Returns the AVR time (s) just before the write
    (the commands arrived later) and the answering frames."""
    frames = []
    for msg in messages:
        seq = dev._next_seq()
        frames.append((seq, msg.TYPE, MsgType[msg.REPLY], encode_message(msg, seq)))
    data = b"".join(f[3] for f in frames)
    t_before = board.sim_time_s
    dev.link.write(data)
    replies = [dev._await(seq, mtype, rtype, timeout_s) for seq, mtype, rtype, _ in frames]
    return t_before, replies


def _on_now(dev, setpoint_dkpa: int = -200, mask: int = 0b111):
    """The SET_OUTPUTS the SDK would send next (this session, next counter)."""
    dev._out_counter += 1
    return m.SetOutputs(
        setpoint_dkpa=(setpoint_dkpa,) * 3,
        pump_mask=mask,
        valve_mask=mask,
        session=dev._session,
        counter=dev._out_counter,
    )


def _cut_after(board, t_sent_s: float, timeout_s: float = 60.0) -> float:
    """Waits until every output is off; returns the AVR time (s) from the last host command to
    the first logged tick with all outputs off. The last command of a burst is read only after
    the SET_OUTPUTS ahead of it has run, so it counts from the first tick (after ``t_sent_s``,
    the time before the write) with the outputs on: never later than the true time (within
    the 1 ms tick), so the result bounds the silence the watchdog allowed from above."""
    from porosense.simboard.board import PinState

    def all_off(t) -> bool:
        q = PinState.from_tick(t)
        return not any(q.pumps) and not any(q.valves) and q.regulator_duty == (0, 0, 0)

    board.run_for(0.002)
    board.wait_for(all_off, timeout=timeout_s)
    rows = [r for r in list(board.truth) if r["t"] >= t_sent_s]
    t_on = next((r["t"] for r in rows if _any_on(r)), None)
    assert t_on is not None, "the outputs never came on"
    t_ref = t_on
    off = next(r["t"] for r in rows if r["t"] > t_ref and not _any_on(r))
    return off - t_ref


def test_host_lost_during_calibration_at_the_slowest_adc_rate(elf) -> None:
    """8 SPS: 64 samples of 3 channels would block for 24 s; the board refuses it while an
    output is on, so the watchdog still cuts the outputs in time."""
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.config_set("ADC_RATE", 0)
        dev.set_watchdog(WATCHDOG_MS)
        t_last, (on, reply) = _burst(board, dev, [_on_now(dev), m.CalibrateR0(n_samples=64, channel_mask=0b111)])
        silent = _cut_after(board, t_last)
        print(
            f"calibration at 8 SPS: {reply and reply.message()}; outputs cut {silent * 1000:.1f} ms "
            f"after the last command (timeout {WATCHDOG_MS} ms)"
        )
        assert reply is not None and reply.message().code == Result.BUSY
        assert silent <= WATCHDOG_MS / 1000 + MARGIN_S
        # With the outputs off, the slow calibration runs and answers.
        dev.config_set("ADC_RATE", 7)
        assert len(dev.calibrate_r0(4, 0b111)) == 3
    finally:
        dev.close()
        board.close()


def test_host_lost_during_a_flash(elf) -> None:
    """A model chunk writes 118 EEPROM bytes (0.4 s): the host starts a flash with the pumps on
    and vanishes after the first chunk."""
    blob = fw.heavy_model_blob()
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.set_watchdog(WATCHDOG_MS)
        begin = m.ModelBegin(length=len(blob), crc=int.from_bytes(blob[-2:], "little"), format_version=blob[2])
        t_last, (on, _, reply) = _burst(board, dev, [_on_now(dev), begin, m.ModelChunk(offset=0, data=blob[:118])])
        silent = _cut_after(board, t_last)
        print(
            f"flash with outputs on: {reply and reply.message()}; outputs cut {silent * 1000:.1f} ms "
            f"after the last command"
        )
        assert silent <= WATCHDOG_MS / 1000 + MARGIN_S
        assert reply is not None and reply.message().code == Result.BUSY
    finally:
        dev.close()
        board.close()


def test_host_lost_while_streaming_at_the_highest_rate(elf) -> None:
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        fw.store_in_flash(board, dev, fw.heaviest_storable_blob())  # the heaviest model any store holds
        rate = fw.advertised_max_rate_hz()
        dev.start_stream(rate, 0x1F)
        list(dev.samples(rate // 2, timeout_s=15))
        dev.set_watchdog(WATCHDOG_MS)
        t_last, _ = _burst(board, dev, [_on_now(dev), m.Ping(nonce=1)])
        silent = _cut_after(board, t_last)
        samples = dev.drain_samples()
        print(
            f"{rate} Hz, every channel + IMU + estimator: outputs cut {silent * 1000:.1f} ms after the "
            f"last command; {len(samples)} samples meanwhile, {dev.stats.samples_lost} lost"
        )
        assert silent <= WATCHDOG_MS / 1000 + MARGIN_S
        assert dev.status().overruns == 0
    finally:
        dev.close()
        board.close()


def test_host_lost_while_sampling_at_the_slowest_adc_rate(elf) -> None:
    """At 8 SPS one sample of three channels takes 375 ms, longer than the 100 ms watchdog:
    the watchdog is kept inside the conversion waits, not only between samples. (Commands wait
    for the sample in progress, so STATUS is not asked here: its 50 ms deadline cannot hold.)"""
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.config_set("ADC_RATE", 0)
        dev.start_stream(10, 0x07)
        dev.set_watchdog(100)
        # Read while the board is busy sampling: answers may miss their 50 ms deadline.
        t_last, _ = _burst(board, dev, [_on_now(dev), m.Ping(nonce=1)], timeout_s=2.0)
        silent = _cut_after(board, t_last)
        print(f"streaming at 8 SPS: outputs cut {silent * 1000:.1f} ms after the last command (timeout 100 ms)")
        assert silent <= 0.100 + MARGIN_S
    finally:
        dev.close()
        board.close()


class _Echo(threading.Thread):
    """An echoing adapter: every byte the board sends goes straight back to it."""

    def __init__(self, link):
        super().__init__(daemon=True)
        self.link, self.stop, self.bytes = link, threading.Event(), 0

    def run(self) -> None:
        while not self.stop.is_set():
            data = self.link.read(0.01)
            if data:
                self.link.write(data)
                self.bytes += len(data)


def test_loopback_does_not_feed_the_watchdog(elf) -> None:
    # Real time and a 1 s watchdog: the echo thread has a second of wall time to send the
    # board's frames back before the cut, even on a busy host.
    timeout_ms = 1000
    board, dev = _open(elf, truth_every_ms=1.0, max_speed=1.0)
    try:
        dev.start_stream(50, 0x07)  # the board talks: SAMPLE frames to echo
        dev.set_watchdog(timeout_ms)
        t_last, _ = _burst(board, dev, [_on_now(dev), m.Ping(nonce=1)])
        echo = _Echo(dev.link)
        echo.start()
        try:
            silent = _cut_after(board, t_last)
        finally:
            echo.stop.set()
            echo.join(timeout=5)
        print(
            f"loopback: {echo.bytes} bytes echoed; outputs cut {silent * 1000:.1f} ms after the last command "
            f"(timeout {timeout_ms} ms)"
        )
        assert echo.bytes > 500  # > 12 SAMPLE frames came back
        assert silent <= timeout_ms / 1000 + MARGIN_S
    finally:
        dev.close()
        board.close()


def test_skipped_ticks_are_counted_as_lost_samples(elf) -> None:
    """At 250 SPS three conversions take 12 ms: 100 Hz cannot be sustained, and every skipped
    tick must show on the host as a lost sample, not only as the OVERRUN flag."""
    board, dev = _open(elf)
    try:
        dev.config_set("ADC_RATE", 5)
        before = dev.status().overruns
        dev.start_stream(100, 0x07)
        block = dev.read_samples(100, timeout_s=15)
        dev.stop_stream()
        overruns = dev.status().overruns - before
        print(
            f"100 Hz at 250 SPS: {overruns} ticks skipped, host counted {dev.stats.samples_lost} lost "
            f"({block.lost} in the block of {len(block.t_us)})"
        )
        assert overruns > 20
        # Every skipped tick is a gap, up to the samples that arrived after the last one read.
        assert block.lost > 20 and 0 <= overruns - dev.stats.samples_lost <= 2
    finally:
        dev.close()
        board.close()


def test_replayed_set_outputs_cannot_turn_pumps_on(elf) -> None:
    board, dev = _open(elf)
    try:
        dev.set_outputs(-30.0, pumps=0b111, valves=0b111)
        on = m.SetOutputs(
            setpoint_dkpa=(-300, -300, -300), pump_mask=7, valve_mask=7, session=dev._session, counter=dev._out_counter
        )
        dev.set_outputs()  # off
        board.run_for(0.02)
        assert not any(board.pins.pumps)
        replies = [dev.exchange_raw(MsgType.SET_OUTPUTS, on.pack(), timeout_s=2.0) for _ in range(2)]
        board.run_for(0.02)
        assert not any(board.pins.pumps) and not any(board.pins.valves)
        # A new connection (HELLO) opens a new session: the old frame stays refused.
        dev.hello()
        replies.append(dev.exchange_raw(MsgType.SET_OUTPUTS, on.pack(), timeout_s=2.0))
        board.run_for(0.02)
        print("replayed 'pumps on':", [r and r.message() for r in replies])
        assert all(r is not None and r.message().code == Result.BAD_STATE for r in replies)
        assert not any(board.pins.pumps)
        dev.set_outputs(-30.0, pumps=0b001)  # the live host still can
        board.run_for(0.02)
        assert board.pins.pumps == (True, False, False)
        dev.set_outputs()
    finally:
        dev.close()
        board.close()
