"""The emulator's own features: sensor faults, power loss, real-time pacing, pty, determinism."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "device"))  # tests/device/models.py
from models import make_blob  # noqa: E402

from porosense.device import Device, NakError
from porosense.emulator import Emulator, Faults
from porosense.errors import DeviceError
from porosense.protocol import Result, StatusFlag
from porosense.protocol._messages import CONFIG_SPECS, VERSION_MAJOR, ConfigKey
from porosense.quant import ModelBlob


def test_adc_unplugged_while_streaming_is_flagged_and_reported_once():
    with Emulator(seed=1) as emu, Device.open(emu.url) as dev:
        dev.start_stream(100)
        before = list(dev.samples(20))
        emu.disconnect(adc=True)
        for first in dev.samples(20000):  # samples made before the unplug may still be on their way
            if first.status & StatusFlag.ADC_FAULT:
                break
        faulty = [first] + list(dev.samples(29))
        dev.stop_stream()
        assert not any(s.status & StatusFlag.ADC_FAULT for s in before)
        assert all(s.status & StatusFlag.ADC_FAULT and s.adc == (0, 0, 0) for s in faulty)
        reports = [e for e in dev.errors if e.code == Result.SENSOR_FAULT]
        assert len(reports) == 1 and reports[0].detail == StatusFlag.ADC_FAULT
        assert reports[0].t_us == first.t_us
        assert dev.stats.samples_lost == 0  # the ERROR frame is part of the telemetry sequence
        assert dev.status().sensor_faults >= len(faulty)
        with pytest.raises(NakError) as err:
            dev.calibrate_r0(4, 1)
        assert err.value.code == Result.SENSOR_FAULT
        emu.disconnect(adc=False)
        dev.start_stream(100)
        assert not list(dev.samples(3))[-1].status & StatusFlag.ADC_FAULT
        dev.stop_stream()


def test_imu_unplugged_at_boot():
    with Emulator(actuator="3dof", faults=Faults(imu_disconnect=True)) as emu, Device.open(emu.url) as dev:
        assert "IMU" not in dev.info.capabilities and "ADC" in dev.info.capabilities
        assert dev.info.n_channels == 3
        dev.start_stream(50, channels=["ADC0", "ADC1", "ADC2", "IMU"])
        s = list(dev.samples(5))[-1]
        dev.stop_stream()
        assert s.status & StatusFlag.IMU_FAULT and s.euler_16 == (0, 0, 0)
        assert all(a > 0 for a in s.adc)


def test_power_loss_in_the_middle_of_a_model_write_keeps_the_old_model():
    old, new = make_blob(1), make_blob(3, model_id=7, poles=0.8)
    faults = Faults(reset_after_model_bytes=len(old) + 150)  # inside the second chunk of `new`
    with Emulator(faults=faults) as emu, Device.open(emu.url) as dev:
        assert dev.write_model(old).valid
        with pytest.raises(DeviceError):
            dev.write_model(new)
        assert emu.core.stats.reboots_injected == 1
        info = dev.model_info()
        assert (
            info.status == "valid" and info.model_id == ModelBlob.from_bytes(old).model_id
        )  # two slots: the old one runs
        assert dev.status().reset_cause == 0x01  # power-on
        assert dev.write_model(new).valid  # the store works after the loss


def test_power_cut_after_a_number_of_received_bytes():
    with Emulator(faults=Faults(reset_after_rx_bytes=100)) as emu, Device.open(emu.url) as dev:
        for i in range(20):  # 12 bytes per PING: the cut lands in the 8th or 9th
            assert dev.ping(nonce=i).nonce == i  # the retry reaches the rebooted board
        assert emu.core.stats.boots == 2 and emu.core.stats.reboots_injected == 1
        assert dev.status().reset_cause == 0x01


def test_power_cut_while_streaming_stops_the_stream():
    with Emulator() as emu, Device.open(emu.url) as dev:
        dev.set_outputs(-20, pumps=1, valves=1)
        dev.start_stream(100)
        list(dev.samples(10))
        emu.reset_now()
        in_flight = 0
        with pytest.raises(DeviceError, match="no SAMPLE"):
            for _ in dev.samples(100_000, timeout_s=0.3):  # what was on its way, then silence
                in_flight += 1
        assert in_flight < 100_000
        info = dev.hello()
        assert info.streaming is False and info.uptime_ms < 2000
        assert not dev.status().has(StatusFlag.OUTPUTS_ACTIVE)


def test_realtime_pacing():
    """Real time: 25 samples at 50 Hz cannot arrive before 0.48 s of wall clock have passed."""
    with Emulator(realtime=True) as emu, Device.open(emu.url) as dev:
        dev.start_stream(50)
        t0 = time.monotonic()
        samples = list(dev.samples(25))
        wall = time.monotonic() - t0
        dev.stop_stream()
    assert wall >= 0.47
    assert np.all(np.diff([s.t_us for s in samples]) == 20_000)


def test_lockstep_clock_advances_one_period_per_sample():
    with Emulator() as emu, Device.open(emu.url) as dev:
        dev.start_stream(100)
        samples = list(dev.samples(1000))  # 10 s of device time, as fast as the host reads
        dev.stop_stream()
        after = dev.ping().device_time_us
    assert (samples[-1].t_us - samples[0].t_us) == 999 * 10_000
    assert after >= samples[-1].t_us


@pytest.mark.skipif(sys.platform == "win32", reason="no pseudo-terminals")
def test_pty_endpoint():
    with Emulator(listen="pty") as emu:
        assert emu.url.startswith("/dev/")
        with Device.open(emu.url, handshake_timeout_s=1.0) as dev:
            dev.start_stream(100)
            assert len(list(dev.samples(50))) == 50
            dev.stop_stream()
            assert dev.stats.samples_lost == 0


def test_device_clock_wrap_is_unwrapped():
    with Emulator(clock_offset_us=2**32 - 300_000) as emu, Device.open(emu.url) as dev:
        dev.start_stream(100)
        samples = list(dev.samples(100))
        dev.stop_stream()
    raw = [s.t_us & 0xFFFFFFFF for s in samples]
    assert min(raw) < 1_000_000 < 2**32 - 1_000_000 < max(raw)  # the wrap happened inside
    assert np.all(np.diff([s.t_us for s in samples]) == 10_000)


def test_vacuum_collapses_the_foam_and_venting_recovers():
    with Emulator(actuator="3dof", seed=3) as emu, Device.open(emu.url) as dev:
        dev.set_watchdog(10000)
        dev.start_stream(100)
        rest = dev.read_samples(50)
        dev.set_outputs([-40, -40, 0], pumps=0b011, valves=0b011)
        on = dev.read_samples(600)
        dev.set_outputs()
        off = dev.read_samples(1500)
        dev.stop_stream()
    r0 = rest.dr_centi.mean(axis=0)
    assert np.all(np.abs(r0[:3]) < 300)  # dR about 0 at rest after the boot R0 calibration
    assert np.all(on.dr_centi[-50:, :2].mean(axis=0) < -2000)  # channels 0, 1 under vacuum
    assert abs(on.dr_centi[-50:, 2].mean()) < 500  # channel 2 idle
    assert np.all(np.abs(off.dr_centi[-50:, :2].mean(axis=0)) < 1000)  # back near R0
    assert np.all(on.status[-1:] & StatusFlag.OUTPUTS_ACTIVE)


def test_protocol_minor_differences_are_accepted_major_refused():
    with Emulator(proto_version=(VERSION_MAJOR, 3)) as emu, Device.open(emu.url) as dev:
        assert dev.info.proto_minor == 3
    with Emulator(proto_version=(VERSION_MAJOR + 1, 0)) as emu:
        with pytest.raises(DeviceError, match=rf"protocol {VERSION_MAJOR + 1}\.0"):
            Device.open(emu.url)


def test_realtime_link_runs_at_115200_baud():
    """Real time: 20 MODEL_DATA replies of 120 bytes need at least 20 x 10.4 ms on the wire."""
    blob = make_blob(3, model_id=7, poles=0.8)
    with Emulator(realtime=True) as emu, Device.open(emu.url) as dev:
        dev.write_model(blob)
        t0 = time.monotonic()
        for _ in range(4):
            assert dev.read_model() == blob  # 575 bytes: 5 replies each
        wall = time.monotonic() - t0
        rate = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max
        dev.start_stream(rate)  # 39-byte SAMPLEs at the highest rate fit in 115200 baud: nothing dropped
        samples = list(dev.samples(100))
        dev.stop_stream()
        assert dev.status().dropped_telemetry == 0
    assert wall >= 20 * 124 * 10 / 115200
    # Whole 1 kHz ticks: periods of floor or ceil(1000 / rate) ms, the exact rate on average.
    period = np.diff([s.t_us for s in samples])
    assert set(np.unique(period)) <= {1000 * (1000 // rate), 1000 * -(-1000 // rate)}
    assert abs(period.mean() - 1e6 / rate) <= 1e6 / rate / len(period) * 2


_STREAM_IN_A_FRESH_PROCESS = r"""
import json, sys
import porosense.quant.fixed as reference
from porosense.device import Device
from porosense.emulator import Emulator

calls = []
def _poisoned(*args, **kwargs):  # the Python fixed-point reference must never run here
    calls.append(1)
    raise RuntimeError("the Python fixed-point reference was called")
for name in ("pwl_eval", "_section"):
    setattr(reference, name, _poisoned)
reference.FixedPointEstimator.__init__ = _poisoned
blob = open(sys.argv[1], "rb").read()
with Emulator(seed=5) as emu, Device.open(emu.url) as dev:
    dev.write_model(blob)
    dev.start_stream(100)
    samples = list(dev.samples(300))
    dev.stop_stream()
print(json.dumps({"dr": [list(s.dr_centi) for s in samples], "est": [list(s.estimate) for s in samples],
                  "reference_calls": len(calls)}))
"""


def test_estimates_are_made_by_the_firmware_core(tmp_path):
    """The emulator's estimates come from the C++ estimator: in its process the Python fixed-point
    reference is poisoned and never called, and the reference (here only an oracle) agrees bit for bit."""
    import json
    import subprocess

    from models import reference_run

    blob = make_blob(3, model_id=9, poles=0.8)
    (tmp_path / "model.bin").write_bytes(blob)
    proc = subprocess.run(
        [sys.executable, "-c", _STREAM_IN_A_FRESH_PROCESS, str(tmp_path / "model.bin")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["reference_calls"] == 0
    dr, est = np.array(out["dr"], dtype=np.int16), np.array(out["est"], dtype=np.int16)
    assert np.ptp(est[:, 0]) > 0  # the model responds to the boot transient and noise
    assert np.array_equal(est, reference_run(blob, dr))


def test_a_driving_board_leads_a_silent_host_by_at_most_the_lockstep_lead():
    """Lockstep makes samples as fast as the host reads, and the socket buffers hold thousands.
    While the board drives the plant its clock may lead the host's last frame by at most
    LOCKSTEP_LEAD_S plus the wall time since: otherwise a host pinging every few samples looks
    silent to the link watchdog (measured without the bound: about 37 s of device time in a
    0.3 s pause at 100 Hz). Bound: the lead plus the pause plus one sample period."""
    from porosense.emulator.emulator import LOCKSTEP_LEAD_S

    with Emulator() as emu, Device.open(emu.url) as dev:
        dev.set_watchdog(10000)
        dev.start_stream(100)
        dev.set_outputs(-10.0, pumps=1)
        t0, w0 = dev.ping().device_time_us, time.monotonic()
        time.sleep(0.3)  # the host reads nothing
        t1, wall = dev.ping().device_time_us, time.monotonic() - w0
        dev.set_outputs(0.0)
        dev.stop_stream()
    lead = (t1 - t0) / 1e6
    print(f"device time between the pings {lead:.3f} s over {wall:.3f} s of wall time")
    assert lead <= LOCKSTEP_LEAD_S + wall + 1 / 100
