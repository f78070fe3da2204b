"""The virtual ADS1115 as the firmware sees it through Arduino's Wire library."""

from __future__ import annotations

import math

import pytest

from porosense.simboard import ConstantPlant, SimBoard

pytestmark = pytest.mark.simboard

VOLTS = (1.0, 2.5, 4.0)  # exact in float32, so the expected codes are exact
FSR = (6.144, 4.096, 2.048, 1.024, 0.512, 0.256)
DATA_RATES = (8, 16, 32, 64, 128, 250, 475, 860)


def config(mux: int, pga: int, dr: int, single_shot: bool = True, start: bool = True) -> int:
    return (start << 15) | (mux << 12) | (pga << 9) | (single_shot << 8) | (dr << 5) | 0x03


def expected_code(volts: float, pga: int) -> int:
    return max(-32768, min(32767, math.floor(volts / FSR[pga] * 32768)))


@pytest.fixture(scope="module")
def board(testfw):
    with SimBoard(testfw, plant=ConstantPlant(VOLTS, (0.0, 0.0, 0.0))) as b:
        yield b


@pytest.fixture
def console(board, console_for):
    return console_for(board)


def single_shot(console, cfg: int) -> tuple[int, int, int, int]:
    reply = console.ask(f"a{cfg:04x}").split()
    assert reply[0] == "a" and reply[1] != "ERR", reply
    code, us, polls, first_os = (int(x) for x in reply[1:])
    return code, us, polls, first_os


@pytest.mark.parametrize("pga", range(6))
def test_plant_voltages_appear_as_counts_for_the_pga(console, pga):
    for ch, volts in enumerate(VOLTS):
        code, *_ = single_shot(console, config(4 + ch, pga, dr=7))
        assert code == expected_code(volts, pga), (ch, volts, FSR[pga])


def test_differential_inputs(console):
    code, *_ = single_shot(console, config(0, 1, dr=7))  # AIN0 - AIN1
    assert code == expected_code(VOLTS[0] - VOLTS[1], 1) == -12000
    code, *_ = single_shot(console, config(3, 1, dr=7))  # AIN2 - AIN3 (AIN3 at 0 V)
    assert code == expected_code(VOLTS[2], 1)


@pytest.mark.parametrize("dr", range(8))
def test_conversion_time_is_one_over_data_rate(console, dr):
    code, us, polls, first_os = single_shot(console, config(4, 1, dr))
    nominal_us = 1e6 / DATA_RATES[dr]
    # the firmware starts timing after the config write's STOP and stops after the first
    # poll that sees OS = 1: one 400 kHz register read (about 0.1 ms) of slack
    assert nominal_us - 50 <= us <= nominal_us + 300, (DATA_RATES[dr], us)
    assert first_os == 0 and polls >= 2  # OS reads 0 while converting, 1 when done
    assert code == expected_code(VOLTS[0], 1)


def test_config_reads_back_with_os_set_when_idle(console):
    cfg = config(6, 2, dr=5)
    single_shot(console, cfg)
    assert console.ask("r1").split()[1] == f"{cfg | 0x8000:X}"


def test_continuous_mode_converts_at_the_data_rate(board, console):
    assert console.ask(f"c{config(5, 1, dr=7, single_shot=False, start=False):04x}") == "c 0"
    _, _, us0 = console.ask("r0").split()
    n0 = board.counters["adc_conversions"]
    board.run_for(0.2)
    _, value, us1 = console.ask("r0").split()
    n1 = board.counters["adc_conversions"]
    assert int(value, 16) == expected_code(VOLTS[1], 1)
    # conversions completed between the two reads, timed by the AVR's micros()
    elapsed_s = (int(us1) - int(us0)) * 1e-6
    assert elapsed_s >= 0.2
    assert abs((n1 - n0) - elapsed_s * 860) <= 2, (n1 - n0, elapsed_s)
    assert console.ask(f"c{config(4, 1, dr=7, start=False):04x}") == "c 0"  # back to single shot


def test_absent_adc_nacks_and_comes_back(board, console):
    nacks = board.counters["twi_nacks"]
    board.set_absent(ads=True)
    assert console.ask(f"a{config(4, 1, 7):04x}") == "a ERR 2"  # Wire: address NACK
    assert console.ask("b").startswith("b A0")  # the IMU still answers
    assert board.counters["twi_nacks"] > nacks
    board.set_absent(ads=False)
    assert single_shot(console, config(4, 1, 7))[0] == expected_code(VOLTS[0], 1)
