"""``porosense config``: show, set and reset the device configuration stored in EEPROM."""

from __future__ import annotations

import argparse
import textwrap

from porosense.cli._data import add_json_options, emit_json
from porosense.errors import DeviceError, InputError

# Unit of each key's value (the catalogue states it in prose; the table is printed from this).
UNITS = {
    "SAMPLE_RATE_HZ": "Hz",
    "CHANNEL_MASK": "bits",
    "R0_MODE": "0/1",
    "R0_CH0_MOHM": "mOhm",
    "R0_CH1_MOHM": "mOhm",
    "R0_CH2_MOHM": "mOhm",
    "ADC_PGA": "code",
    "ADC_RATE": "code",
    "MIN_SETPOINT_DKPA": "0.1 kPa",
    "WATCHDOG_MS": "ms",
    "AUTOSTART": "0/1",
    "PWM_PIN": "pin (0 or 10)",
    "PWM_SCALE_MILLI": "0.001 duty/LSB",
    "PWM_OFFSET": "duty",
    "LINE_MODE": "0/1",
    "SCHEDULE_ENABLE": "0/1",
}


def register(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "config",
        help="show, set or reset the device configuration (EEPROM)",
        description=textwrap.fill(
            "The device configuration lives in EEPROM (two 32-byte slots with a CRC, written "
            "atomically). 'show' lists every key with its value, unit, default and accepted range "
            "(sample rate in Hz, R0 in milliohm, setpoint limit in 0.1 kPa, watchdog in ms, PWM "
            "scale in duty counts per 1000 estimate LSB); 'set KEY VALUE' checks the value, sets it "
            "and saves the configuration; 'reset' restores the documented defaults. A board that "
            "streams on its own (AUTOSTART) stops while EEPROM is written and restarts afterwards."
        ),
        epilog=(
            "examples (on the emulator, porosense emulator; a board is --port /dev/ttyACM0):\n"
            "  porosense config --port socket://127.0.0.1:5000\n"
            "  porosense config --port socket://127.0.0.1:5000 set AUTOSTART 1\n"
            "  porosense config --port socket://127.0.0.1:5000 get SAMPLE_RATE_HZ\n"
            "  porosense config --port socket://127.0.0.1:5000 set pwm_pin 10 --json\n"
            "  porosense config --port socket://127.0.0.1:5000 reset"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--port", required=True, metavar="URL", help="serial port or pyserial URL")
    add_json_options(p, "the configuration")
    p.add_argument(
        "action",
        nargs="?",
        default="show",
        choices=("show", "get", "set", "reset"),
        help="show (default), get KEY, set KEY VALUE, or reset",
    )
    p.add_argument("key", nargs="?", metavar="KEY", help="configuration key (name, any case), for get and set")
    p.add_argument("value", nargs="?", metavar="VALUE", help="integer value in the key's unit, for set")
    p.set_defaults(func=run)
    return p


def parse_setting(key: str | None, value: str | None) -> tuple[str, int]:
    """Check KEY and VALUE against the catalogue (porosense.protocol CONFIG_SPECS); returns
    (KEY, value). Raises InputError naming the accepted keys or range."""
    from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

    if key is None or value is None:
        raise InputError("'set' needs KEY and VALUE, e.g. 'set AUTOSTART 1'")
    name = key.strip().upper()
    if name not in ConfigKey.__members__:
        raise InputError(f"unknown configuration key {key!r}; keys: {', '.join(k.name for k in ConfigKey)}")
    try:
        number = int(value, 0)
    except ValueError:
        raise InputError(f"{name} takes an integer ({UNITS.get(name, '')}), not {value!r}") from None
    spec = CONFIG_SPECS[ConfigKey[name]]
    if not spec.min <= number <= spec.max:
        raise InputError(f"{name} = {number} is outside {spec.min}..{spec.max} {UNITS.get(name, '')}".rstrip())
    return name, number


def config_table(values: dict[str, int]) -> list[dict]:
    """One row per key: name, value, unit, default, min, max, doc."""
    from porosense.protocol._messages import CONFIG_SPECS

    rows = []
    for key, spec in CONFIG_SPECS.items():
        rows.append(
            {
                "key": key.name,
                "value": values.get(key.name),
                "unit": UNITS.get(key.name, ""),
                "default": spec.default,
                "min": spec.min,
                "max": spec.max,
                "doc": spec.doc,
            }
        )
    return rows


def format_table(rows: list[dict]) -> str:
    """The rows as aligned text; '*' marks a value that differs from its default."""
    lines = [f"{'key':<18} {'value':>11}  {'unit':<15} {'default':>9}  range"]
    for r in rows:
        mark = "*" if r["value"] is not None and r["value"] != r["default"] else " "
        value = "?" if r["value"] is None else str(r["value"])
        lines.append(f"{r['key']:<18} {value:>11}{mark} {r['unit']:<15} {r['default']:>9}  {r['min']}..{r['max']}")
    return "\n".join(lines)


def run(args) -> int:
    from porosense.device import Device
    from porosense.device.client import NakError
    from porosense.protocol import StatusFlag

    setting = parse_setting(args.key, args.value) if args.action == "set" else None
    only = None
    if args.action == "get":
        if args.key is None or args.value is not None:
            raise InputError("'get' takes one KEY, e.g. 'get SAMPLE_RATE_HZ'")
        only = args.key.strip().upper()
        if only not in UNITS:
            raise InputError(f"unknown configuration key {args.key!r}; keys: {', '.join(UNITS)}")
    elif args.action != "set" and (args.key is not None or args.value is not None):
        raise InputError(f"'{args.action}' takes no KEY or VALUE")
    with Device.open(args.port) as dev:
        info = dev.hello()
        note = []
        if args.action in ("set", "reset"):
            restart = _stop_if_streaming(dev, info)
            try:
                if setting is not None:
                    try:
                        dev.config_set(*setting)
                    except NakError as exc:
                        raise DeviceError(_explain(exc, setting)) from None
                    dev.config_save()
                    note.append(f"{setting[0]} = {setting[1]} saved")
                else:
                    dev.config_reset()
                    note.append("defaults restored and saved")
            finally:
                if restart:
                    _restart_stream(dev)
                    note.append("stream restarted")
        values = dev.config_all()
        flags = dev.status().flags
    defaults_in_use = bool(flags & StatusFlag.CONFIG_DEFAULTS)
    rows = config_table(values)
    if only is not None:
        rows = [r for r in rows if str(r.get("key", "")).upper() == only]
    emit_json(
        {"port": args.port, "action": args.action, "config_defaults": defaults_in_use, "notes": note, "keys": rows},
        args,
    )
    if args.json:
        return 0
    print(format_table(rows))
    if defaults_in_use:
        print(
            "note: the stored configuration was missing or corrupt; documented defaults are in use "
            "(CONFIG_DEFAULTS) until it is saved"
        )
    for n in note:
        print(n)
    return 0


def _stop_if_streaming(dev, info) -> bool:
    """EEPROM writes are refused while sampling: stop a stream (autostart) first."""
    if not info.streaming:
        return False
    from porosense.protocol import _messages as m

    dev.command(m.StopStream())
    dev.drain_samples()
    return True


def _restart_stream(dev) -> None:
    # Sent as a bare command: the client must not stop it again when it closes.
    from porosense.protocol import _messages as m

    rate = dev.config_get("SAMPLE_RATE_HZ")
    mask = dev.config_get("CHANNEL_MASK")
    dev.command(m.StartStream(rate_hz=rate, channel_mask=mask))


def _explain(exc, setting) -> str:
    code = getattr(exc.code, "name", str(exc.code))
    key, value = setting
    if code == "UNSUPPORTED":
        if key == "SCHEDULE_ENABLE":
            return "stored schedules are not available in this firmware (no EEPROM room): SCHEDULE_ENABLE stays 0"
        if key == "PWM_PIN":
            return f"pin {value} cannot carry the analogue output: its timer is in use; use PWM_PIN 10 (or 0 for off)"
        return f"{key} = {value} is not supported by this firmware"
    return f"the device refused {key} = {value}: {code}"
