"""Strain control in the real firmware (simboard): a sensor fault mid-move vents with a flag,
a target beyond what the actuator reaches saturates (flagged) without the command ever passing
MIN_SETPOINT_DKPA, AUTOSTART 2 runs the stored trajectory with no host, and control at 100 Hz
on the heaviest storable model keeps 0 overruns with the stack's high-water mark reported.

Times and outputs are the AVR's (SAMPLE timestamps, the plant's per-tick pin log)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from test_firmware_simboard import _open, elf  # noqa: F401  (the built ELF fixture)

from porosense.bench import firmware as fw
from porosense.device import ControlGains
from porosense.protocol import StatusFlag as F

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "device"))
from control_samples import controlled_samples  # noqa: E402
from models import make_blob  # noqa: E402

pytestmark = [pytest.mark.simboard, pytest.mark.xdist_group("firmware-build")]

GAINS = ControlGains(kp_kpa=2.0, ki_kpa_per_s=4.0, slew_per_s=50.0)
STACK_MARGIN_B = 150  # the RAM budget's stated margin (firmware/Makefile)


def _controlled(dev, n, limit=4000, ping_every=20, ping=True):
    return controlled_samples(dev, n, limit=limit, timeout_s=30, ping_every=ping_every, ping=ping)


def test_sensor_fault_mid_move_vents_with_a_flag(elf) -> None:
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.write_model(make_blob(1))
        scale = dev.model_info().out_scale[0]
        dev.set_watchdog(5000)
        dev.start_stream(100, 0x11)
        dev.set_control_gains(GAINS)
        dev.start_control(12000 * scale)  # this model's estimate rises with vacuum
        before = _controlled(dev, 30)
        board.set_absent(ads=True)
        during = list(dev.samples(40, timeout_s=15))
        board.set_absent(ads=False)
        dev.stop_stream()
        assert all(s.status & F.CONTROL_ACTIVE for s in before)
        assert before[-1].command_kpa[0] < -1.0  # moving: vacuum on when the sensor goes
        hit = next(i for i, s in enumerate(during) if s.status & F.ADC_FAULT)
        # The faulty sample itself already reports the vent: no command is held on it.
        assert all(s.status & F.CONTROL_ABORTED for s in during[hit:])
        assert not any(s.status & (F.CONTROL_ACTIVE | F.OUTPUTS_ACTIVE) for s in during[hit:])
        assert not any(board.pins.pumps) and not any(board.pins.valves)
        assert board.pins.regulator_duty == (0, 0, 0)
    finally:
        dev.close()
        board.close()


@pytest.mark.parametrize("target_lsb", [-29900, 29900])
def test_target_beyond_the_stroke_saturates_within_the_limit(elf, target_lsb) -> None:
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.write_model(make_blob(1))
        scale = dev.model_info().out_scale[0]
        dev.config_set("MIN_SETPOINT_DKPA", -300)
        dev.set_watchdog(5000)
        dev.start_stream(100, 0x11)
        # 1 kPa per 100 LSB of error and a fast slew: the command pins within a few samples.
        dev.set_control_gains(ControlGains(kp_kpa=0.01 / scale, ki_kpa_per_s=0.0, slew_per_s=1e5 * scale))
        dev.start_control(target_lsb * scale)
        s = _controlled(dev, 200)
        dev.stop_control()
        dev.stop_stream()
        cmd = np.array([x.command_kpa[0] for x in s])
        assert cmd.min() >= -30.0 and cmd.max() <= 0.0  # never beyond MIN_SETPOINT_DKPA
        # The actuator cannot reach it: the last second is pinned at a limit and flagged.
        tail = s[-100:]
        assert all(x.status & F.CONTROL_SATURATED for x in tail)
        assert np.all(np.isin(cmd[-100:], (0.0, -30.0)))
        duty = [r["p_cmd_0"] for r in board.truth]
        assert min(duty) >= -30.0 - 0.5  # the regulator's setpoint as driven on the pins
    finally:
        dev.config_set("MIN_SETPOINT_DKPA", -600)
        dev.close()
        board.close()


def test_autostart_runs_the_stored_trajectory_without_a_host(elf) -> None:
    board, dev = _open(elf, truth_every_ms=1.0)
    try:
        dev.write_model(make_blob(1))
        scale = dev.model_info().out_scale[0]
        dev.config_set("SAMPLE_RATE_HZ", 50)
        dev.config_set("CHANNEL_MASK", 0x01)
        dev.config_set("WATCHDOG_MS", 200)
        dev.config_set("AUTOSTART", 2)
        dev.config_save()
        dev.write_trajectory([0.0, 1.0, 3.0], [0.0, 12000 * scale, 12000 * scale], repeat=True)
        dev.set_control_gains(GAINS, save=True)  # made for 50 Hz: the autostart rate
        dev.link.close()  # no host from here on
        board.reset()
        t0 = board.sim_time_s
        board.run_for(3.0)
        rows = [r for r in list(board.truth) if r["t"] > t0 + 0.5]
        assert rows
        # Controlling channel 0 long past the 200 ms watchdog: its valve stays open and the
        # regulator follows the trajectory's vacuum demand, never beyond the limit.
        assert all(r["valve_0"] for r in rows)
        p = np.array([r["p_cmd_0"] for r in rows])
        assert p.min() < -1.0 and p.min() >= -60.0
        assert not any(r["valve_1"] or r["valve_2"] for r in rows)
    finally:
        board.close()


def test_control_keeps_the_cycle_budget_and_stack_margin(elf) -> None:
    board, dev = _open(elf, actuator="3dof")  # three wired sensors: the 3-input model stays in range
    try:
        blob = fw.heavy_model_blob()
        dev.write_model(blob, replace=True)
        dev.calibrate_r0(16, 0x07)
        # The deepest command paths too: a full REPLAY and a full MODEL_READ.
        dev.replay(np.full((16, 3), -2000))
        assert dev.read_model() == blob
        dev.set_watchdog(5000)
        dev.start_stream(100, 0x1F)
        scale = dev.model_info().out_scale
        # Per channel: 1 kPa per 100 LSB, 1 kPa per (100 LSB s), 1000 LSB/s.
        dev.set_control_gains([ControlGains(0.01 / c, 0.01 / c, 1000 * c) for c in scale])
        dev.start_control(0.0, channels=0b111)
        s = _controlled(dev, 300)
        dev.stop_control()
        dev.stop_stream()
        st = dev.status()
        print(st, dev.errors[-3:])
        print(
            f"control at 100 Hz on 3 channels, {len(blob)}-byte model (after a model write, R0 "
            f"calibration, REPLAY, MODEL_READ): {st.overruns} overruns, free stack {st.free_ram} B "
            f"(high-water since boot)"
        )
        assert len(s) == 300
        assert st.overruns == 0
        assert st.free_ram >= STACK_MARGIN_B
    finally:
        dev.close()
        board.close()
