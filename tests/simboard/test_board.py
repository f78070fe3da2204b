"""The board around the sensors: UART over TCP, pins, the plant loop, EEPROM, resets, speed."""

from __future__ import annotations

import math
import random
import socket
import time

import pytest

from porosense.errors import DeviceError
from porosense.simboard import BringupPlant, SimBoard, measure_speed

pytestmark = pytest.mark.simboard


@pytest.fixture
def board(testfw):
    with SimBoard(testfw, plant=BringupPlant()) as b:
        yield b


def test_uart_round_trip_over_tcp(board, console_for):
    con = console_for(board)
    rng = random.Random(6)
    alphabet = "abcdefghijklmnopqrstuvwxyz0123456789 -_.:"
    lines = ["e" + "".join(rng.choice(alphabet) for _ in range(rng.randint(1, 50))) for _ in range(60)]
    for line in lines[:30]:
        assert con.ask(line) == line.rstrip()
    # a burst of lines sent at once: paced by the line rate and the UART's XON/XOFF
    rx0 = board.counters["uart_rx"]
    con.port.write("".join(line + "\n" for line in lines[30:]).encode())
    assert [con.read_line() for _ in lines[30:]] == [line.rstrip() for line in lines[30:]]
    assert board.counters["uart_rx"] - rx0 == sum(len(line) + 1 for line in lines[30:])


def test_pump_and_valve_pins_are_observed(board, console_for):
    con = console_for(board)
    for mask in (0b000000, 0b000001, 0b000010, 0b000100, 0b001000, 0b010000, 0b100000, 0b101010, 0b111111):
        assert con.ask(f"p{mask:02x}") == "p OK"
        board.run_for(0.002)
        pins = board.pins
        assert pins.pumps == tuple(bool(mask >> i & 1) for i in range(3)), mask
        assert pins.valves == tuple(bool(mask >> (i + 3) & 1) for i in range(3)), mask


def test_regulator_duty_gives_the_setpoint(board, console_for):
    con = console_for(board)
    for pin, duty in ((5, 128), (6, 64), (9, 200)):
        assert con.ask(f"o{pin},{duty}") == "o OK"
    board.run_for(0.05)
    pins = board.pins
    assert pins.regulator_duty == (128, 64, 200)
    assert pins.setpoint_kpa == pytest.approx((-80 * 128 / 255, -80 * 64 / 255, -80 * 200 / 255))
    assert board.truth[-1]["p_cmd_0"] == pytest.approx(-80 * 128 / 255)
    assert con.ask("o5,0") == "o OK" and con.ask("o9,255") == "o OK"  # digitalWrite ends
    board.run_for(0.005)
    assert board.pins.regulator_duty == (0, 64, 255)


def test_plant_closes_the_loop_through_the_adc(board, console_for):
    con = console_for(board)
    rest = int(con.ask("a c383").split()[1])  # AIN0, +-4.096 V, 128 SPS
    assert con.ask("p09") == "p OK"  # pump 0 and valve 0 on
    assert con.ask("o5,255") == "o OK"  # full vacuum on channel 0
    board.run_for(2.0)  # > 6 time constants
    code = int(con.ask("a c383").split()[1])
    v = board.truth[-1]["v_0"]
    assert abs(code - math.floor(v / 4.096 * 32768)) <= 40, (code, v)
    assert rest - code > 10000  # the sensor resistance fell
    assert board.truth[-1]["p_0"] < -75.0


def test_eeprom_survives_reset_and_restart(testfw, tmp_path, console_for):
    image = tmp_path / "board.eeprom"
    with SimBoard(testfw, plant=BringupPlant(), eeprom=image) as b:
        con = console_for(b)
        assert con.ask("W64,8,170") == "W OK"
        b.reset()
        assert b.counters["resets"] == 1
        assert con.ask("R70") == "R 170"
    data = image.read_bytes()
    assert len(data) == 1024 and data[64:72] == bytes([170]) * 8 and data[72] == 0xFF
    with SimBoard(testfw, plant=BringupPlant(), eeprom=image) as b:
        assert console_for(b).ask("R71") == "R 170"


def test_reset_after_eeprom_writes_tears_a_write(board, console_for):
    con = console_for(board)
    writes = board.counters["eeprom_writes"]
    board.reset_after_eeprom_writes(3)
    con.port.write(b"W100,10,9\n")
    assert con.read_line() == "boot 2"  # reset before "W OK"; MCUSR: EXTRF, the reset button
    image = board.eeprom_image()
    assert image[100:103] == bytes([9]) * 3 and image[103:110] == b"\xff" * 7
    assert board.counters["eeprom_writes"] - writes == 3
    assert con.ask("R101") == "R 9"


def test_reset_at_a_chosen_time(board, console_for):
    con = console_for(board)
    con.ask("t")
    # Ahead of the AVR by more than a loaded host stalls this thread: the board runs faster than
    # real time, and at 1.0 s a stall at load average 6 let it pass the time first (reset at 1.011).
    at = board.sim_time_s + 5.0
    board.reset(at_s=at)
    tick = board.wait_for(lambda t: t.resets == 1)
    assert at <= tick.time_s <= at + 0.0021
    assert con.read_line() == "boot 2"  # MCUSR: EXTRF, an external reset
    assert int(con.ask("t").split()[1]) < 100  # millis() restarted


def test_watchdog_reset_is_followed(board, console_for):
    con = console_for(board)
    before = board.sim_time_s
    con.port.write(b"z\n")
    assert con.read_line() == "boot 8"  # MCUSR.WDRF
    assert board.counters["resets"] == 1 and board.sim_time_s > before
    assert con.ask("ealive") == "ealive"


def test_faster_than_real_time(board, console_for):
    con = console_for(board)
    for idle_sleep in (0, 1):
        con.ask(f"i{idle_sleep}")
        t0, wall0 = board.sim_time_s, time.monotonic()
        board.run_for(1.5)
        ratio = (board.sim_time_s - t0) / (time.monotonic() - wall0)
        print(f"simboard speed, {'sleeping' if idle_sleep else 'busy'} idle loop: {ratio:.2f} x real time")
    assert ratio > 1.0, ratio
    assert board.cycles == round(board.sim_time_s * 16e6)


def test_missing_files_raise_device_error(testfw, tmp_path):
    with pytest.raises(DeviceError, match="firmware ELF not found"):
        SimBoard(tmp_path / "absent.elf", plant=BringupPlant())
    with pytest.raises(DeviceError, match="harness not found"):
        SimBoard(testfw, plant=BringupPlant(), harness=tmp_path / "simboard")
    not_elf = tmp_path / "not.elf"
    not_elf.write_text("not an ELF")
    with pytest.raises(DeviceError, match="did not start.*not a loadable AVR ELF"):
        SimBoard(not_elf, plant=BringupPlant()).start()


def test_reset_on_connect_shows_the_boot_banner(testfw):
    # A plain socket: pyserial's socket:// open() discards whatever already arrived, and the
    # harness (no bootloader delay) can reset and print the banner before that open returns.
    with SimBoard(testfw, plant=BringupPlant(), reset_on_connect=True) as b:
        b.run_for(0.05)
        for expected_resets in (1, 2):  # every open resets, like DTR
            with socket.create_connection(("127.0.0.1", b.port), timeout=10) as conn:
                assert conn.makefile("rb").readline() == b"boot 2\r\n"  # EXTRF: DTR pulls RESET low
                assert b.counters["resets"] == expected_resets


def test_measure_speed_reports_avr_time(testfw):
    report = measure_speed(testfw, seconds=0.5, plant=BringupPlant())
    assert 0.5 <= report.sim_time_s <= 0.5 + 0.0011  # one plant period of overshoot
    assert report.cycles >= 0.5 * 16e6 and report.to_dict()["ratio"] > 0


def test_power_cycle_resets_the_sensors_too(board, console_for):
    con = console_for(board)
    assert con.ask("c" + "c583") == "c 0"  # ADS1115: MUX AIN0, single shot
    assert con.ask("m0c").startswith("m ")  # BNO055 into NDOF
    board.power_cycle()
    board.run_for(0.7)  # the BNO055 boots for 650 ms
    con.sync()
    assert con.ask("r1").split()[1] == "8583"  # ADS1115 power-on config
    assert con.ask("u") == "u 0 0 0 0 0"  # BNO055 back in CONFIGMODE
    assert board.counters["resets"] == 1
