"""``porosense config`` against the emulator: show lists every key with value, unit, default and
range; set checks, sets and saves (it survives a reset); reset restores the defaults; user
mistakes and refused values end with one clear line; a streaming board is stopped for the
EEPROM write and restarted."""

from __future__ import annotations

import json

import pytest

from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

MAX_HZ = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max  # the one source: protocol/messages.toml


@pytest.fixture()
def emu():
    from porosense.emulator import Emulator

    with Emulator(actuator="contractor") as e:
        yield e


def _run(capsys, *argv) -> tuple[int, str, str]:
    from porosense.cli import main

    code = main(["config", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_show_lists_every_key_with_default_and_range(emu, capsys) -> None:
    from porosense.protocol._messages import CONFIG_SPECS

    code, out, _ = _run(capsys, "--port", emu.url, "show", "--json")
    assert code == 0
    doc = json.loads(out)
    rows = {r["key"]: r for r in doc["keys"]}
    assert set(rows) == {k.name for k in CONFIG_SPECS}
    for key, spec in CONFIG_SPECS.items():
        r = rows[key.name]
        assert (r["default"], r["min"], r["max"]) == (spec.default, spec.min, spec.max)
        assert r["unit"]
        if not key.name.startswith("R0_CH"):  # R0 is measured at boot
            assert r["value"] == spec.default
    code, text, _ = _run(capsys, "--port", emu.url)  # show is the default action
    assert code == 0 and len(text.splitlines()) >= len(CONFIG_SPECS) + 1
    assert "SAMPLE_RATE_HZ" in text and "Hz" in text and f"10..{MAX_HZ}" in text


def test_set_saves_and_reset_restores(emu, capsys) -> None:
    from porosense.device import Device

    code, out, _ = _run(capsys, "--port", emu.url, "set", "sample_rate_hz", str(MAX_HZ), "--json")
    assert code == 0
    rows = {r["key"]: r for r in json.loads(out)["keys"]}
    assert rows["SAMPLE_RATE_HZ"]["value"] == MAX_HZ
    with Device.open(emu.url) as dev:
        dev.reset()  # the value was saved: it comes back from EEPROM
        assert dev.config_get("SAMPLE_RATE_HZ") == MAX_HZ
    code, out, _ = _run(capsys, "--port", emu.url, "reset", "--json")
    assert code == 0
    assert {r["key"]: r for r in json.loads(out)["keys"]}["SAMPLE_RATE_HZ"]["value"] == 50
    with Device.open(emu.url) as dev:
        dev.reset()
        assert dev.config_get("SAMPLE_RATE_HZ") == 50


@pytest.mark.parametrize(
    "args, words",
    [
        (("set", "BOGUS", "1"), "unknown configuration key"),
        (("set", "SAMPLE_RATE_HZ", "500"), f"outside 10..{MAX_HZ}"),
        (("set", "SAMPLE_RATE_HZ", "fast"), "takes an integer"),
        (("set", "SAMPLE_RATE_HZ"), "needs KEY and VALUE"),
        (("set", "SCHEDULE_ENABLE", "1"), "stored schedules are not available"),
        (("set", "PWM_PIN", "9"), "use PWM_PIN 10"),
    ],
)
def test_mistakes_give_one_clear_line(emu, capsys, args, words) -> None:
    code, out, err = _run(capsys, "--port", emu.url, *args)
    assert code != 0
    assert words in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_set_while_streaming_restarts_the_stream(emu, capsys) -> None:
    from porosense.device import Device
    from porosense.protocol import _messages as m

    with Device.open(emu.url) as dev:
        dev.command(m.StartStream(rate_hz=50, channel_mask=0x07))  # left running on exit
    code, out, _ = _run(capsys, "--port", emu.url, "set", "WATCHDOG_MS", "700")
    assert code == 0 and "stream restarted" in out
    with Device.open(emu.url) as dev:
        assert dev.info.streaming and dev.config_get("WATCHDOG_MS") == 700
        dev.command(m.StopStream())


def test_emulator_line_mode_matches_the_reference(model_blob) -> None:
    """The emulator mirrors the firmware's line mode: header, then lines that the reference
    estimator, formatted like the firmware, reproduces byte for byte."""
    import time

    import numpy as np
    from line_format import format_line

    from porosense.device import Device
    from porosense.emulator import Emulator
    from porosense.protocol import _messages as m
    from porosense.protocol import encode_message
    from porosense.quant import FixedPointEstimator, ModelBlob

    blob = ModelBlob.from_bytes(model_blob)
    with Emulator(actuator="contractor") as emu:
        with Device.open(emu.url) as dev:
            dev.write_model(model_blob)
            for key, value in (("AUTOSTART", 1), ("LINE_MODE", 1)):
                dev.config_set(key, value)
            dev.config_save()
            # RESET sent without waiting for its ACK (the wait would read the lines as noise);
            # then listen on the same link without sending a frame (one would end line mode).
            dev.send_raw(encode_message(m.Reset(), 7))
            data = bytearray()
            end = time.monotonic() + 10.0
            while data.count(b"\r\n") < 60 and time.monotonic() < end:
                data += dev.link.read(0.05)
    text = bytes(data)[bytes(data).index(b"\x00") + 1 :]  # after the ACK frame
    lines = text.split(b"\r\n")[:-1]
    assert lines[0] == b"t_ms,dR0,dR1,dR2,est0,est1"
    rows = [ln.decode().split(",") for ln in lines[1:]]
    assert len(rows) >= 59
    t_ms = np.array([int(r[0]) for r in rows])
    assert np.all(np.diff(t_ms) == 20)
    dr = np.array([[round(float(v) * 100) for v in r[1:4]] for r in rows], dtype=np.int16)
    ref = FixedPointEstimator(blob)
    ref.reset()
    est, _ = ref.run(dr)
    scale = list(blob.out_scale) + [0.0] * (3 - blob.n_outputs)
    expected = [format_line(t, 7, d, blob.n_outputs, e, scale)[:-2] for t, d, e in zip(t_ms, dr, est)]
    assert sum(a != b for a, b in zip(lines[1:], expected)) == 0
