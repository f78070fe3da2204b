"""The highest sample rate is written once, as SAMPLE_RATE_HZ's max in messages.toml: the
generated catalogue, the demo's --rate check and every document that quotes the advertised
maximum say the same number (`porosense bench firmware --size full` measures it)."""

from __future__ import annotations

import re
from pathlib import Path

from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

ROOT = Path(__file__).resolve().parents[2]
MAX_HZ = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ].max


def test_documents_quote_the_catalogue_limit():
    hw = (ROOT / "docs" / "hardware.md").read_text()
    quoted = re.findall(r"advertised maximum \(SAMPLE_RATE_HZ limits, START_STREAM\) is \*\*(\d+) Hz\*\*", hw)
    quoted += re.findall(r"up to the advertised maximum, (\d+) Hz", hw)
    figures = (ROOT / "docs" / "figures.md").read_text()
    quoted += re.findall(r"advertised maximum rate[^|]*\| (\d+) Hz", figures)
    spec = (ROOT / "protocol" / "spec.md").read_text()
    quoted += re.findall(r"\| SAMPLE_RATE_HZ \| \d+ \| \d+ \| (\d+) \|", spec)
    assert len(quoted) == 4, quoted
    assert {int(q) for q in quoted} == {MAX_HZ}


def test_demo_rate_check_uses_the_catalogue_limit(capsys):
    from porosense.cli import main

    assert main(["demo", "--rate", str(MAX_HZ + 1)]) == 2
    err = capsys.readouterr().err
    assert f"outside 10..{MAX_HZ}" in err and len(err.strip().splitlines()) == 1
