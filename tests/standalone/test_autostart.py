"""A flashed board senses on its own: in the simboard, a model and AUTOSTART=1 are saved, the
AVR is reset with no host attached, and the SAMPLE frames on the serial line carry estimates
bit-exact with the Python reference (porosense.quant.FixedPointEstimator) on the same inputs;
the analogue output on D10 follows estimate 0 within one PWM step; pumps and valves stay off;
a host attaches afterwards without a reset."""

from __future__ import annotations

import numpy as np
import pytest
from standalone_kit import HANDSHAKE_S, STANDALONE, RawCapture, SwingPlant, configure

pytestmark = [pytest.mark.simboard]

PWM_SCALE_MILLI = 1500  # duty counts per 1000 estimate LSB
PWM_OFFSET = 128
CAPTURE_AVR_S = 1.5


def expected_duty(estimate0: int) -> int:
    """duty = clamp(estimate * PWM_SCALE_MILLI / 1000 + PWM_OFFSET, 0, 255), truncating."""
    q = int(estimate0 * PWM_SCALE_MILLI / 1000)  # toward zero, as the firmware's C division
    return min(255, max(0, q + PWM_OFFSET))


def test_autostart_streams_bit_exact_estimates_and_pwm(elf, model_blob) -> None:
    from porosense.device import Device
    from porosense.protocol import FrameDecoder, MsgType
    from porosense.protocol import _messages as m
    from porosense.quant import FixedPointEstimator, ModelBlob
    from porosense.simboard import SimBoard

    plant = SwingPlant()
    # At most 2x real time, so the wall-time polling below sees the D10 duty often enough.
    with SimBoard(elf, plant=plant, max_speed=2.0) as board:
        configure(
            board,
            model_blob,
            {"AUTOSTART": 1, "PWM_PIN": 10, "PWM_SCALE_MILLI": PWM_SCALE_MILLI, "PWM_OFFSET": PWM_OFFSET},
        )
        cap = RawCapture(board.url)
        try:
            board.reset()  # power-up with no host: nothing is sent to the board from here on
            t_boot = board.sim_time_s
            observations = []  # (AVR time since reset in us, duty on D10)
            rx_before = board.counters["uart_rx"]
            while board.sim_time_s - t_boot < CAPTURE_AVR_S:
                cap.poll(0.002)
                p = board.pins
                observations.append(((p.time_s - t_boot) * 1e6, p.pwm_duty[10], any(p.pumps) or any(p.valves)))
            cap.poll(0.05)
            assert board.counters["uart_rx"] == rx_before  # no host spoke
        finally:
            cap.close()

        frames = FrameDecoder().feed(bytes(cap.data))
        samples = [f.message() for f in frames if f.type == MsgType.SAMPLE]
        seqs = [f.seq for f in frames if f.type == MsgType.SAMPLE]
        print(f"{len(samples)} SAMPLE frames in {CAPTURE_AVR_S} s of AVR time after the reset")
        assert len(samples) >= 0.8 * 50 * (CAPTURE_AVR_S - 0.3)  # 50 Hz default, after the boot
        assert seqs == list(range(len(seqs)))  # the stream's first frame onwards, none lost
        assert all(s.status & STANDALONE for s in samples)

        # Bit-exact against the reference fed the same dR (all three channels are streamed).
        dr = np.array([s.dr_centi for s in samples], dtype=np.int16)
        est = np.array([s.estimate for s in samples], dtype=np.int16)
        ref = FixedPointEstimator(ModelBlob.from_bytes(model_blob))
        ref.reset()
        ref_est, _ = ref.run(dr)
        n_out = ModelBlob.from_bytes(model_blob).n_outputs
        mismatches = int(np.sum(ref_est[:, :n_out] != est[:, :n_out]))
        spread = int(np.ptp(est[:, 0]))
        print(f"estimates: {mismatches} mismatches in {est[:, :n_out].size} values; estimate 0 spans {spread} LSB")
        assert mismatches == 0
        assert spread >= 20  # the inputs move, so the comparison means something

        # PWM on D10: each observation matches the duty of the latest or the previous sample
        # taken before it (the duty is written a few ms after the sample tick).
        t_us = np.array([s.t_us for s in samples], dtype=np.int64)
        duty_ref = [expected_duty(int(e)) for e in est[:, 0]]
        checked, bad = 0, []
        for t_obs, duty, _ in observations:
            k = int(np.searchsorted(t_us, t_obs + 1500, side="right"))  # 1.5 ms: reset timing
            if k < 2:
                continue
            checked += 1
            if min(abs(duty - duty_ref[k - 1]), abs(duty - duty_ref[k - 2])) > 1:
                bad.append((t_obs, duty, duty_ref[k - 2], duty_ref[k - 1]))
        distinct = len({d for _, d, _ in observations})
        print(f"PWM D10: {checked} observations, {len(bad)} off by more than one step, {distinct} distinct duties")
        assert checked >= 30 and not bad[:5]
        assert distinct >= 8
        # Standalone: pumps and valves stay off.
        assert not any(active for _, _, active in observations)
        assert plant.pumps_seen == 0

        # Hot attach: a host opens the link mid-stream, HELLO works, the stream goes on.
        resets = board.counters["resets"]
        with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
            info = dev.info
            assert info.streaming
            got = list(dev.samples(25, timeout_s=HANDSHAKE_S))
            assert all(s.status & STANDALONE for s in got)
            assert np.all(np.diff([s.seq for s in got]) % 256 == 1)
            st = dev.status()
            assert st.flags & STANDALONE
            # Stored schedules do not exist in this build; D9 is the regulator's timer.
            for key, value in (("SCHEDULE_ENABLE", 1), ("PWM_PIN", 9)):
                with pytest.raises(Exception) as err:
                    dev.config_set(key, value)
                assert getattr(err.value, "code", None) == m.Result.UNSUPPORTED
            print(
                f"hot attach: HELLO answered at uptime {info.uptime_ms} ms, {len(got)} samples read, "
                f"{dev.stats.stale_replies} stale frames"
            )
        assert board.counters["resets"] == resets  # attaching did not reset the board
