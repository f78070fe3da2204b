"""`porosense bench device`: the figures it reports (timings are printed, not asserted)."""

from __future__ import annotations

import pytest


@pytest.mark.bench
def test_bench_device_small():
    from porosense.bench.device import run

    result = run("small")
    emu = result["emulator"]
    assert emu["samples"] == 4000 and emu["lost"] == 0
    from porosense.bench.device import RATE_HZ

    # Samples fall on the 1 kHz tick: the span is the exact one within one tick.
    assert emu["device_s"] == pytest.approx(3999 / RATE_HZ, abs=1e-3)
    assert len(result["summary"]) == 4
    assert result["board"]["samples"] == 4000 and result["board"]["samples_per_cpu_s"] > 0
    if result["simboard"] is not None:
        assert result["simboard"]["lost"] == 0
    print("\n".join(result["summary"]))
