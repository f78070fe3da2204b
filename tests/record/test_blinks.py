"""The host's decoding of the sync indicator agrees with the firmware's header and its docs."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from porosense.record import blinks

HEADER = Path(__file__).resolve().parents[2] / "firmware" / "lib" / "core" / "sync_blink.h"


def test_constants_match_the_firmware_header():
    text = HEADER.read_text(encoding="utf-8")
    values = {m.group(1): int(m.group(2)) for m in re.finditer(r"constexpr uint\d+_t (k\w+) = (\d+);", text)}
    assert values["kSyncPin"] == blinks.PIN
    assert values["kSyncStartOnMs"] == blinks.START_ON_MS
    assert values["kSyncStartGapMs"] == blinks.START_GAP_MS
    assert values["kSyncStartOn2Ms"] == blinks.START_ON2_MS
    assert values["kSyncPeriodMs"] == blinks.PERIOD_MS
    assert values["kSyncPulseMs"] == blinks.PULSE_MS


def test_board_edges_at_the_documented_times():
    """50 Hz samples from an arbitrary device clock value: edges at 0, 0.4, 0.6, 0.8 s (start
    code), then 4k and 4k + 0.2 s, alternating polarity."""
    t_us = 1_234_567 + np.arange(50 * 21) * 20_000
    t, pol = blinks.board_edges(t_us)
    expect = [0.0, 0.4, 0.6, 0.8, 4.0, 4.2, 8.0, 8.2, 12.0, 12.2, 16.0, 16.2, 20.0, 20.2]
    np.testing.assert_allclose(t, expect, atol=1e-9)
    assert list(pol) == [1, -1] * 7


def test_edges_fall_on_sample_ticks_at_an_odd_rate():
    """At 30 Hz the 400 ms boundary is not a tick: the switch happens at the first tick after."""
    t_us = np.round(np.arange(30 * 5) * 1e6 / 30).astype(np.int64)
    t, _ = blinks.board_edges(t_us)
    assert abs(t[1] - 12 / 30) < 1e-6  # 400 ms -> tick 12 (400.0 ms) exactly
    assert abs(t[2] - 18 / 30) < 1e-6  # 600 ms -> tick 18
