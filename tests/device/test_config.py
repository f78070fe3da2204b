"""Conformance: configuration keys, their defaults and limits, save and reset."""

from __future__ import annotations

import pytest

from porosense.device import NakError
from porosense.protocol import Result, StatusFlag
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey


def test_defaults_after_config_reset(dev):
    dev.config_reset()
    values = dev.config_all()
    expected = {k.name: CONFIG_SPECS[k].default for k in ConfigKey}
    # R0 is measured at boot when R0_MODE is 0, so only its range is fixed.
    for k in ("R0_CH0_MOHM", "R0_CH1_MOHM", "R0_CH2_MOHM"):
        spec = CONFIG_SPECS[ConfigKey[k]]
        assert spec.min <= values.pop(k) <= spec.max
        expected.pop(k)
    assert values == expected
    assert not dev.status().has(StatusFlag.CONFIG_DEFAULTS)


def test_unknown_keys(dev):
    for key in (0, 17, 255):
        for call in (lambda: dev.config_get(key), lambda: dev.config_set(key, 0)):
            with pytest.raises(NakError) as err:
                call()
            assert err.value.code == Result.BAD_KEY, key


# Keys whose values a build may refuse as UNSUPPORTED (feature or pin absent on that board).
BUILD_DEPENDENT = {ConfigKey.PWM_PIN, ConfigKey.SCHEDULE_ENABLE, ConfigKey.LINE_MODE}


def test_limits_of_every_key(dev):
    for key in ConfigKey:
        spec = CONFIG_SPECS[key]
        before = dev.config_get(key)
        allowed = {Result.OUT_OF_RANGE} | ({Result.UNSUPPORTED} if key in BUILD_DEPENDENT else set())
        for bad in (spec.min - 1, spec.max + 1):
            with pytest.raises(NakError) as err:
                dev.config_set(key, bad)
            assert err.value.code in allowed and err.value.detail == 1, (key.name, bad)
        assert dev.config_get(key) == before, f"a refused CONFIG_SET changed {key.name}"
        safe = [spec.min, spec.max]
        if key in (ConfigKey.AUTOSTART, ConfigKey.LINE_MODE):  # keep the board talking frames
            safe = [spec.min]
        for v in safe:
            try:
                dev.config_set(key, v)
            except NakError as err:
                assert key in BUILD_DEPENDENT and err.code == Result.UNSUPPORTED, (key.name, v)
                assert dev.config_get(key) == before
            else:
                assert dev.config_get(key) == v, key.name
        dev.config_set(key, before)


def test_saved_configuration_survives_a_reset(dev):
    dev.config_reset()
    try:
        dev.config_set("WATCHDOG_MS", 1234)
        dev.config_set("ADC_RATE", 6)
        dev.config_save()
        dev.config_set("WATCHDOG_MS", 4321)  # RAM only: lost at the reset
        dev.reset()
        assert dev.config_get("WATCHDOG_MS") == 1234
        assert dev.config_get("ADC_RATE") == 6
    finally:
        dev.config_reset()
    dev.reset()
    assert dev.config_get("WATCHDOG_MS") == CONFIG_SPECS[ConfigKey.WATCHDOG_MS].default


def test_save_and_reset_are_refused_while_streaming(dev):
    dev.start_stream(50)
    for call in (dev.config_save, dev.config_reset):
        with pytest.raises(NakError) as err:
            call()
        assert err.value.code == Result.BUSY
    dev.stop_stream()
