"""``porosense config get KEY``: one key, as MATLAB users expect from get/set pairs."""

from __future__ import annotations

import json

from porosense.cli import main


def test_config_get_prints_one_key(capsys):
    from porosense.emulator import Emulator

    with Emulator(actuator="contractor") as emu:
        assert main(["config", "--port", emu.url, "get", "sample_rate_hz", "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert [r["key"] for r in doc["keys"]] == ["SAMPLE_RATE_HZ"] and doc["keys"][0]["unit"] == "Hz"
        assert main(["config", "--port", emu.url, "get", "NO_SUCH_KEY"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "unknown configuration key" in err
