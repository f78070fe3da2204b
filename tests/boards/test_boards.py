"""Boards opened by name: the names parse as documented, and a simulated board's link watchdog is
set long enough that a paused host computer does not vent a run (its clock runs EMULATOR_SPEED
times faster than this computer's)."""

from __future__ import annotations

import time

import pytest

from porosense.boards import EMULATOR_SPEED, SIM_WATCHDOG_MS, open_board, parse_port
from porosense.errors import InputError
from porosense.protocol import StatusFlag


def test_names_parse_as_documented():
    assert parse_port("emulator") == ("emulator", "contractor")
    assert parse_port("simboard:3dof") == ("simboard", "3dof")
    assert parse_port("emulator", "bending") == ("emulator", "bending")
    assert parse_port("/dev/ttyACM0") == ("url", None)
    assert parse_port("socket://127.0.0.1:5000") == ("url", None)
    for bad in ("", "emulator:octopus"):
        with pytest.raises(InputError):
            parse_port(bad)


def test_an_actuator_that_disagrees_with_the_name_is_refused():
    with pytest.raises(InputError, match="names actuator"):
        with open_board("emulator:bending", actuator="contractor"):
            pass


def _silent_host_trips(board, pause_board_s: float) -> bool:
    dev = board.device
    dev.set_outputs(-20.0, pumps=1, valves=1)
    time.sleep(pause_board_s / EMULATOR_SPEED)
    tripped = dev.status().has(StatusFlag.WATCHDOG_TRIPPED)
    dev.set_outputs()
    return tripped


def test_a_paused_host_does_not_vent_a_simulated_board():
    """Outputs on, then 3 s of board time without a frame: past the firmware's default 1 s
    watchdog, inside SIM_WATCHDOG_MS. The same pause with the default trips (the check can fail)."""
    assert SIM_WATCHDOG_MS >= 5000
    with open_board("emulator", seed=1) as board:
        assert board.simulated and board.truth is not None and board.upload is not None
        assert not _silent_host_trips(board, 3.0)
        board.device.set_watchdog(1000)
        assert _silent_host_trips(board, 3.0)
