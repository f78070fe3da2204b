"""A corrupt configuration block falls back to the documented defaults with the
CONFIG_DEFAULTS flag, never to garbage: the EEPROM image is corrupted on purpose (both slots:
one with a broken CRC, one with a valid CRC around an out-of-range value) between two runs of
the simboard, and the board boots with every key at its catalogue default."""

from __future__ import annotations

import pytest
from standalone_kit import CONFIG_DEFAULTS, HANDSHAKE_S

pytestmark = [pytest.mark.simboard]

SLOT = 32  # bytes per configuration slot; slots at EEPROM 0 and 32 (firmware device_config.h)


def _reseal(slot: bytearray) -> None:
    """Write a valid CRC-16/MCRF4XX over the first 30 bytes of ``slot`` (little-endian)."""
    from porosense.protocol import crc16

    slot[30:32] = crc16(bytes(slot[:30])).to_bytes(2, "little")


def test_corrupt_configuration_falls_back_to_defaults(elf, tmp_path) -> None:
    from porosense.device import Device
    from porosense.protocol._messages import CONFIG_SPECS
    from porosense.simboard import SimBoard

    image = tmp_path / "eeprom.bin"
    changed = {"SAMPLE_RATE_HZ": 100, "WATCHDOG_MS": 500, "PWM_OFFSET": 17}
    with SimBoard(elf, eeprom=image) as board:
        with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
            for key, value in changed.items():
                dev.config_set(key, value)
            dev.config_save()  # slot 1 (the boot saved slot 0 with the boot counter)
            dev.config_set("PWM_OFFSET", 18)
            dev.config_save()  # slot 0: both slots hold a valid copy now
    data = bytearray(image.read_bytes())
    assert data[0] == 1 and data[SLOT] == 1  # format byte of both slots

    # The same image boots with the saved values (the store works before it is corrupted).
    with SimBoard(elf, eeprom=image) as board:
        with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
            assert dev.config_get("SAMPLE_RATE_HZ") == 100 and dev.config_get("PWM_OFFSET") == 18
            assert not dev.status().flags & CONFIG_DEFAULTS

    # Slot 0: a flipped byte breaks its CRC. Slot 1: a sample rate of 250 Hz (limit 200) with
    # a CRC that matches, so only the range check can refuse it.
    data = bytearray(image.read_bytes())
    data[12] ^= 0x5A
    slot1 = bytearray(data[SLOT : 2 * SLOT])
    slot1[2] = 250
    _reseal(slot1)
    data[SLOT : 2 * SLOT] = slot1
    image.write_bytes(bytes(data))

    with SimBoard(elf, eeprom=image) as board:
        with Device.open(board.url, handshake_timeout_s=HANDSHAKE_S, timeout_scale=4.0) as dev:
            flags = dev.status().flags
            values = dev.config_all()
            dev.start_stream(values["SAMPLE_RATE_HZ"], 0x07)
            samples = list(dev.samples(5, timeout_s=HANDSHAKE_S))
            dev.stop_stream()
            # R0 is measured at boot (R0_MODE 0, the default): in range, not necessarily 1 kOhm.
            r0 = {k: v for k, v in values.items() if k.startswith("R0_CH")}
            wrong = {k: v for k, v in values.items() if k not in r0 and v != CONFIG_SPECS[_key(k)].default}
            print(f"after corrupting both slots: flags 0x{flags:04X}, keys off their default: {wrong}")
            assert flags & CONFIG_DEFAULTS
            assert all(s.status & CONFIG_DEFAULTS for s in samples)
            assert wrong == {}
            assert all(CONFIG_SPECS[_key(k)].min <= v <= CONFIG_SPECS[_key(k)].max for k, v in r0.items())
            # Saving makes the defaults the stored configuration and clears the flag.
            dev.config_save()
            assert not dev.status().flags & CONFIG_DEFAULTS


def _key(name: str):
    from porosense.protocol._messages import ConfigKey

    return ConfigKey[name]
