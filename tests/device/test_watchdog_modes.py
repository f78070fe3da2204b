"""A watchdog no mode escapes: in every way the outputs can be on (hosted outputs with and
without a stream, hosted constant and trajectory control, and a board that started a stored
trajectory by itself at power-up (AUTOSTART 2) or only its stream (AUTOSTART 1) and then heard a
host: a plain handshake, a refused model write, a control start, a trajectory restart, a stream
restart followed by a trajectory; or, after AUTOSTART 1, hosted outputs, a refused model write
with them on, a control start, a trajectory start), a host that goes silent has the outputs cut
within the watchdog period plus one sample period.

The cut time is measured on the device's clock: from the last command (a PING, whose PONG
carries the device time it was handled at) to the time of the cut, which the ERROR the board
sends when the watchdog trips carries. Each
test prints its figure; both back-ends run every mode, each in real time (the emulator with
realtime=True, the simboard at max_speed 1), so that the host's own pauses between commands
during the set-up stay far below the watchdog period."""

from __future__ import annotations

import time
from dataclasses import dataclass

import pytest

from porosense.device import ControlGains, NakError
from porosense.protocol import Result, StatusFlag

WATCHDOG_MS = 500
RATE_HZ = 50  # the sample rate of every streamed mode: one period is 20 ms
GAINS = ControlGains(kp_kpa=2.0, ki_kpa_per_s=1.0, slew_per_s=50.0)
PERIOD_MS = 1000 / RATE_HZ


@dataclass
class RealTimeBoard:
    name: str
    url: str
    timeout_scale: float = 1.0


@pytest.fixture(scope="module", params=["emulator", pytest.param("simboard", marks=pytest.mark.simboard)])
def board(request):
    if request.param == "emulator":
        from porosense.emulator import Emulator

        with Emulator(actuator="contractor", seed=1, realtime=True) as emu:
            yield RealTimeBoard("emulator", emu.url)
            assert emu.error is None, f"emulator thread failed: {emu.error!r}"
    else:
        from porosense.simboard import SimBoard

        elf = request.getfixturevalue("simboard_elf")  # builds the firmware and the harness
        with SimBoard(elf=str(elf), actuator="contractor", max_speed=1.0) as sb:
            yield RealTimeBoard("simboard", sb.url, 3.0)


@pytest.fixture
def dev(board):
    from porosense.device import Device

    with Device.open(board.url, timeout_scale=board.timeout_scale, seed=7) as d:
        d.stop_stream()
        d.stop_control()
        d.set_outputs()
        yield d


def _silent_until_trip(dev, timeout_s: float) -> int:
    """Ping once, then only listen until the watchdog's ERROR arrives; returns the cut time in
    device ms after the ping."""
    n_errors = len(dev.errors)
    t0 = dev.ping().device_time_us
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        dev._pump(0.05)  # reads frames, sends nothing
        trips = [
            e for e in dev.errors[n_errors:] if e.code == Result.BAD_STATE and e.detail == StatusFlag.WATCHDOG_TRIPPED
        ]
        if trips:
            cut = (trips[0].t_us - t0) & 0xFFFFFFFF
            assert cut < 1 << 31, "the watchdog tripped before the last command arrived: the host was too slow"
            return cut / 1000
    raise AssertionError(f"no watchdog trip within {timeout_s:.1f} s of silence")


def _check_cut(dev, board, mode: str, bound_ms: float) -> None:
    cut_ms = _silent_until_trip(dev, 5.0 * board.timeout_scale)
    st = dev.status()
    print(f"watchdog cut, {board.name}, {mode}: {cut_ms:.1f} ms after the last command (bound {bound_ms:.0f} ms)")
    # The watchdog counts from the PING's arrival; the PONG is stamped when the command is
    # handled, which can wait for a sample being processed (less than one period, or the board
    # would count overruns): the cut may come up to that much before the period after the stamp.
    assert WATCHDOG_MS - PERIOD_MS <= cut_ms <= bound_ms, cut_ms
    assert not st.has(StatusFlag.OUTPUTS_ACTIVE) and not st.has(StatusFlag.CONTROL_ACTIVE)
    assert st.has(StatusFlag.WATCHDOG_TRIPPED)


def _hosted(dev, mode: str, blob: bytes) -> float:
    """Puts a board in a hosted mode; returns the cut bound (ms)."""
    if mode in ("control", "trajectory"):
        dev.write_model(blob)
        if mode == "trajectory":
            scale = dev.model_info().out_scale[0]
            dev.write_trajectory([0.0, 1.0, 3.0], [0.0, 800 * scale, 800 * scale], repeat=True)
    dev.set_watchdog(WATCHDOG_MS)
    if mode != "outputs":
        dev.start_stream(RATE_HZ, 0x11 if mode in ("control", "trajectory") else 0x01)
    if mode in ("outputs", "outputs+stream"):
        dev.set_outputs(-20.0, pumps=1, valves=1)
    else:
        dev.set_control_gains(GAINS)
        dev.start_control(0.0) if mode == "control" else dev.start_trajectory()
    return WATCHDOG_MS + PERIOD_MS


@pytest.mark.parametrize("mode", ["outputs", "outputs+stream", "control", "trajectory"])
def test_hosted_outputs_are_cut_when_the_host_falls_silent(dev, board, blob, mode):
    bound = _hosted(dev, mode, blob)
    _check_cut(dev, board, mode, bound)
    dev.stop_stream()


def _autostart(dev, blob: bytes, autostart: int, channel_mask: int = 0x01) -> dict:
    """Stores a model, a repeating trajectory, gains and AUTOSTART, then resets the board:
    it starts by itself (the reset's handshake is the first host command it hears). Returns
    the configuration to restore."""
    keep = {k: dev.config_get(k) for k in ("AUTOSTART", "SAMPLE_RATE_HZ", "CHANNEL_MASK", "WATCHDOG_MS")}
    dev.write_model(blob)
    scale = dev.model_info().out_scale[0]
    dev.config_set("SAMPLE_RATE_HZ", RATE_HZ)
    dev.config_set("CHANNEL_MASK", channel_mask)
    dev.config_set("WATCHDOG_MS", WATCHDOG_MS)
    dev.config_set("AUTOSTART", autostart)
    dev.config_save()
    dev.write_trajectory([0.0, 1.0, 3.0], [0.0, 800 * scale, 800 * scale], repeat=True)
    dev.set_control_gains(GAINS, save=True)  # made for SAMPLE_RATE_HZ: the autostart rate
    dev.reset(wait_s=10.0)  # a loaded machine may run the simboard slower than real time
    return keep


def _restore(dev, keep: dict) -> None:
    dev.stop_control()
    dev.stop_stream()
    dev.set_outputs()
    for k, v in keep.items():
        dev.config_set(k, v)
    dev.config_save()


@pytest.mark.parametrize(
    "then", ["hello", "model write", "control start", "trajectory start", "stream restart, trajectory start"]
)
def test_standalone_trajectory_is_guarded_once_a_host_speaks(dev, board, blob, then):
    keep = _autostart(dev, blob, 2)
    try:
        # The board runs its trajectory: a live host (pinging) sees it controlling.
        on = []
        for k, s in enumerate(dev.samples(4 * RATE_HZ, timeout_s=20)):
            if k % 5 == 4:
                dev.ping()
            if s.status & StatusFlag.CONTROL_ACTIVE:
                on.append(s)
                if len(on) >= 5:
                    break
        assert on and all(s.status & StatusFlag.STANDALONE for s in on)
        if then == "model write":
            with pytest.raises(NakError) as e:  # refused: the outputs are on
                dev.write_model(blob)
            assert e.value.code == Result.BUSY
        elif then == "control start":
            dev.start_control(0.0)
        elif then == "trajectory start":
            dev.start_trajectory()
        elif then == "stream restart, trajectory start":
            dev.start_stream(RATE_HZ, 0x11)  # stops the controller: a restarted estimator would jump
            assert not dev.status().has(StatusFlag.OUTPUTS_ACTIVE)
            dev.start_trajectory()
        _check_cut(dev, board, f"AUTOSTART 2 then {then}", WATCHDOG_MS + PERIOD_MS)
    finally:
        _restore(dev, keep)


@pytest.mark.parametrize("then", ["outputs", "outputs, model write", "control start", "trajectory start"])
def test_autostarted_stream_is_guarded_once_a_host_drives_the_outputs(dev, board, blob, then):
    # The stream of AUTOSTART 1 carries the estimates here, so that a host may start control on it.
    keep = _autostart(dev, blob, 1, channel_mask=0x11)
    try:
        st = dev.status()
        assert st.has(StatusFlag.STANDALONE) and not st.has(StatusFlag.OUTPUTS_ACTIVE)
        if then.startswith("outputs"):
            dev.set_outputs(-20.0, pumps=1, valves=1)
        if then == "outputs, model write":
            with pytest.raises(NakError) as e:  # refused: streaming, outputs on
                dev.write_model(blob)
            assert e.value.code == Result.BUSY
        elif then == "control start":
            dev.start_control(0.0)
        elif then == "trajectory start":
            dev.start_trajectory()
        assert dev.status().has(StatusFlag.OUTPUTS_ACTIVE)
        _check_cut(dev, board, f"AUTOSTART 1 then {then}", WATCHDOG_MS + PERIOD_MS)
    finally:
        _restore(dev, keep)
