"""The virtual BNO055: ids, pages, mode-switch delays, Euler angles, status registers."""

from __future__ import annotations

import pytest

from porosense.simboard import ConstantPlant, SimBoard

pytestmark = pytest.mark.simboard

EULER = (10.5, -20.25, 30.0)  # heading, roll, pitch (deg)


@pytest.fixture
def board(testfw):
    with SimBoard(testfw, plant=ConstantPlant((1.0, 1.0, 1.0), EULER)) as b:
        yield b


def test_chip_id_and_page_switching(board, console_for):
    # chip id 0xA0 on page 0; page 1 shows PAGE_ID = 1 and ACC_Config = 0x0D; back to 0
    assert console_for(board).ask("b") == "b A0 0 1 D 0"


def test_mode_switch_delays_and_euler_counts(board, console_for):
    con = console_for(board)
    assert con.ask("u") == "u 0 0 0 0 0"  # CONFIGMODE: no fusion data, idle
    us, polls = (int(x) for x in con.ask("m0c").split()[1:])
    assert 7000 - 50 <= us <= 7000 + 300 and polls > 1, us
    heading, roll, pitch, calib, sys_status = con.ask("u").split()[1:]
    assert (int(heading), int(roll), int(pitch)) == tuple(round(a * 16) for a in EULER)
    assert int(sys_status) == 5  # sensor fusion running
    board.run_for(1.0)
    assert con.ask("u").split()[4] == "FF"  # fully calibrated after a second of fusion
    us, polls = (int(x) for x in con.ask("m00").split()[1:])
    assert 19000 - 50 <= us <= 19000 + 300, us
    assert con.ask("u").split()[1:4] == ["0", "0", "0"]


def test_absent_imu_nacks(board, console_for):
    con = console_for(board)
    board.set_absent(bno=True)
    assert con.ask("b") == "b ERR 2"
    assert con.ask("a c383").split()[0] == "a"  # the ADC still answers
    board.set_absent(bno=False)
    assert con.ask("b").startswith("b A0")


def test_boot_time_nacks_until_ready(testfw, console_for):
    # at most 2x real time, so the first command surely arrives within the boot time
    with SimBoard(testfw, plant=ConstantPlant(), bno_boot_ms=4000, max_speed=2.0) as b:
        con = console_for(b)
        assert b.sim_time_s < 4.0
        assert con.ask("b") == "b ERR 2"
        b.wait_for(lambda t: t.time_s > 4.0)
        assert con.ask("b").startswith("b A0")
