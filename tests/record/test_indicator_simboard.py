"""The real firmware in simavr drives the sync indicator (D11) as the host decodes it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from porosense.record.blinks import PIN, board_edges, indicator_level

pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]


@pytest.fixture(scope="module")
def elf(simboard_elf) -> Path:
    return simboard_elf


def test_d11_follows_the_pattern_while_streaming(elf):
    """Polled over 6 s of a 50 Hz stream, D11 agrees with the pattern decoded from the sample
    times at every poll further than 30 ms from a switch (a switch lands at a sample tick, the
    poll's AVR time and micros() differ by microseconds); it is low once the stream stops."""
    from porosense.device import Device
    from porosense.simboard import SimBoard

    board = SimBoard(elf, max_speed=2.0).start()
    try:
        dev = Device.open(board.url, handshake_timeout_s=15.0)
        try:
            dev.start_stream(50, 0x01)
            t_us, polls = [], []
            for s in dev.samples(300, timeout_s=60):
                t_us.append(s.t_us)
                p = board.pins
                polls.append((p.time_s, (p.level >> PIN) & 1))
            dev.stop_stream()
            board.run_for(0.1)
            after = (board.pins.level >> PIN) & 1
        finally:
            dev.close()
    finally:
        board.close()
    t_us = np.asarray(t_us, dtype=np.int64)
    edges, _ = board_edges(t_us)
    t_poll = np.array([p[0] for p in polls]) * 1e6
    seen = np.array([p[1] for p in polls])
    elapsed_ms = (t_poll - t_us[0]) / 1000.0
    near = np.min(np.abs(elapsed_ms[:, None] - edges[None, :] * 1000.0), axis=1) < 30.0
    expect = indicator_level(np.floor(elapsed_ms / 20.0) * 20.0).astype(int)
    checked = ~near & (elapsed_ms >= 0)
    mismatches = int(np.sum(seen[checked] != expect[checked]))
    print(f"{checked.sum()} polls checked, {mismatches} mismatches, {seen[checked].sum()} on")
    assert checked.sum() > 150 and seen[checked].sum() >= 5
    assert mismatches == 0
    assert after == 0
