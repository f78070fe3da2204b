"""The board's sync indicator pattern, as specified in firmware/lib/core/sync_blink.h.

This module decodes the signal: given the board's sample times it says when the indicator
switched, so the edges seen by a camera can be matched to device time. The pattern is a
documented interface (docs/camera.md); tests/record checks these constants against the header.
"""

from __future__ import annotations

import numpy as np

#: Indicator pin (Arduino D11).
PIN = 11
#: Start code: on for START_ON_MS, off for START_GAP_MS, on for START_ON2_MS (ms).
START_ON_MS, START_GAP_MS, START_ON2_MS = 400, 200, 200
#: After the start code: on for the first PULSE_MS of every PERIOD_MS (ms).
PERIOD_MS, PULSE_MS = 4000, 200


def indicator_level(elapsed_ms) -> np.ndarray:
    """Indicator on (True) at ``elapsed_ms`` (ms since the stream's first sample; < 0: off)."""
    ms = np.floor(np.asarray(elapsed_ms, dtype=float))
    second = START_ON_MS + START_GAP_MS
    start = (ms < START_ON_MS) | ((ms >= second) & (ms < second + START_ON2_MS))
    periodic = np.mod(ms, PERIOD_MS) < PULSE_MS
    return (ms >= 0) & np.where(ms < PERIOD_MS, start, periodic)


def board_levels(t_dev_us) -> np.ndarray:
    """Indicator level set at each board sample (device times in us, first = stream start)."""
    t = np.asarray(t_dev_us, dtype=np.int64)
    return indicator_level((t - t[0]) // 1000)


def board_edges(t_dev_us) -> tuple[np.ndarray, np.ndarray]:
    """Device times (s, from the first sample) and polarities (+1 on, -1 off) of the switches.

    The firmware sets the level at each sample tick, so an edge happens at the tick of the
    first sample with the new level; the stream's first sample switches the indicator on.
    """
    t = np.asarray(t_dev_us, dtype=np.int64)
    level = board_levels(t).astype(int)
    change = np.flatnonzero(np.diff(np.r_[0, level]))
    return (t[change] - t[0]) * 1e-6, np.where(level[change] > 0, 1, -1)
