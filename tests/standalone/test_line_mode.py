"""CSV line mode in the simboard: with LINE_MODE=1 and AUTOSTART=1 stored, the board prints a
header and one parseable CSV line per sample after a reset with no host; the dR columns feed
the Python reference, whose estimates, formatted like the firmware, give the same lines
byte for byte. A host that then speaks frames switches the session back to SAMPLE frames."""

from __future__ import annotations

import numpy as np
import pytest
from standalone_kit import HANDSHAKE_S, STANDALONE, RawCapture, SwingPlant, configure

pytestmark = [pytest.mark.simboard]

CAPTURE_AVR_S = 1.2


def test_line_mode_prints_csv_matching_the_reference(elf, model_blob) -> None:
    from line_format import format_line

    from porosense.device import Device
    from porosense.quant import FixedPointEstimator, ModelBlob
    from porosense.simboard import SimBoard

    blob = ModelBlob.from_bytes(model_blob)
    with SimBoard(elf, plant=SwingPlant()) as board:
        configure(board, model_blob, {"AUTOSTART": 1, "LINE_MODE": 1})
        cap = RawCapture(board.url)
        try:
            dropped0 = board.counters["uart_dropped"]
            board.reset()
            t0 = board.sim_time_s
            while board.sim_time_s - t0 < CAPTURE_AVR_S:
                cap.poll(0.01)
            cap.poll(0.05)
            dropped = board.counters["uart_dropped"] - dropped0
        finally:
            cap.close()

        print(f"UART bytes the harness dropped while capturing: {dropped}")
        text = bytes(cap.data)
        assert b"\x00" not in text  # no frame at all: text only
        lines = text.split(b"\r\n")
        lines = lines[:-1]  # the last piece may be a line still being sent
        header = lines[0].decode()
        print(f"{len(lines) - 1} lines after the header {header!r}; first: {lines[1].decode()!r}")
        assert header == "t_ms,dR0,dR1,dR2," + ",".join(f"est{j}" for j in range(blob.n_outputs))
        rows = [[float(v) for v in ln.decode().split(",")] for ln in lines[1:]]
        assert len(rows) >= 0.8 * 50 * (CAPTURE_AVR_S - 0.3)
        assert all(len(r) == 4 + blob.n_outputs for r in rows)
        t_ms = np.array([r[0] for r in rows], dtype=np.int64)
        assert np.all(np.diff(t_ms) == 20)  # 50 Hz, no line lost
        dr = np.array([[round(v * 100) for v in r[1:4]] for r in rows], dtype=np.int16)
        assert np.ptp(dr[:, 0]) > 1000  # the inputs move (10 % of dR)

        ref = FixedPointEstimator(blob)
        ref.reset()  # the stream starts with a reset estimator, like its first line
        est, _ = ref.run(dr)
        scale = list(blob.out_scale) + [0.0] * (3 - blob.n_outputs)
        expected = [format_line(t, 7, d, blob.n_outputs, e, scale) for t, d, e in zip(t_ms, dr, est)]
        mismatches = sum(a + b"\r\n" != b for a, b in zip(lines[1:], expected))
        print(f"line mode: {mismatches} of {len(expected)} lines differ from the reference")
        assert mismatches == 0

        # A host attaches: its first frame ends line mode for the session.
        with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
            got = list(dev.samples(10, timeout_s=HANDSHAKE_S))
            assert len(got) == 10 and all(s.status & STANDALONE for s in got)
            assert dev.config_get("LINE_MODE") == 1  # stored setting unchanged
            print(f"lines dropped by the firmware (transmit buffer full): {dev.status().dropped_telemetry}")
