"""The bench's core on the real firmware (simboard: the AVR image in simavr over the simulated
contractor): under 500 g the board's controller, on the model and gains identified at 0 g,
leaves less steady-state error against the true strain than the 0 g static map, and what it
leaves is the load's bias of the estimate (the floor from the simulator's steady state) plus the
estimate's bias on a recording it was not identified on: within 2.5 % strain of the floor
(measured 1.77 at seed 9 since the simulated sensor varies between recordings, issue 31)."""

from __future__ import annotations

from pathlib import Path

import pytest

from porosense.control.loadbench import HOLD_S, TARGETS, identify_setup, measure_load

# One worker builds the firmware and the harness: the others would race it in the same build tree.
pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]


@pytest.fixture(scope="module")
def built(simboard_elf) -> Path:
    return simboard_elf


def test_closed_loop_beats_the_open_loop_under_500_g_on_the_firmware(built):
    setup = identify_setup(50, seed=100)
    r = measure_load(setup, 500.0, TARGETS["small"], HOLD_S["small"], seed=9, port="simboard")
    cl = [round(m["steady_error"], 2) for m in r["closed_loop"]]
    ol = [round(m["steady_error"], 2) for m in r["open_loop"]]
    print(
        f"simboard 500 g: closed {r['closed_steady_error']:.2f} {cl}, open {r['open_steady_error']:.2f} {ol}, "
        f"floor {[round(f, 2) for f in r['floor']]}, ratio {r['ratio']:.2f}"
    )
    assert r["closed_steady_error"] < 0.6 * r["open_steady_error"]
    assert max(abs(m["steady_error"] - f) for m, f in zip(r["closed_loop"], r["floor"])) < 2.5
