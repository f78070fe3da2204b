"""The blob / EEPROM store layout is generated from protocol/model_layout.toml for both sides:
the committed model_layout.h and protocol/model_layout.py must be what the generator writes now, and the
Python blob must follow the generated layout."""

import subprocess
import sys
from pathlib import Path

from porosense.protocol import model_layout as layout
from porosense.protocol.model_blob import ModelBlob

ROOT = Path(__file__).resolve().parents[2]
GENERATOR = ROOT / "protocol" / "gen_model_layout.py"


def test_generated_files_are_current():
    proc = subprocess.run([sys.executable, str(GENERATOR), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_check_fails_when_a_generated_file_is_stale(tmp_path, monkeypatch):
    """--check is not a no-op: a changed source makes it fail and name the stale file."""
    sys.path.insert(0, str(GENERATOR.parent))
    try:
        import gen_model_layout as gen
    finally:
        sys.path.pop(0)
    src = tmp_path / "model_layout.toml"
    src.write_text(gen.SOURCE.read_text().replace("format_version = 2", "format_version = 99"))
    monkeypatch.setattr(gen, "SOURCE", src)
    assert gen.main(["--check"]) == 1


def test_python_blob_follows_the_layout():
    import numpy as np

    from porosense.quant import quantize
    from porosense.quant.random_models import random_structure

    blob = quantize(random_structure(np.random.default_rng(1), 2, 2, h1_poles=2, kind="wh")).blob
    data = blob.to_bytes()
    off = layout.HEADER_OFFSETS
    assert data[off["format_version"]] == layout.FORMAT_VERSION
    assert int.from_bytes(data[off["length"] : off["length"] + 2], "little") == len(data)
    assert int.from_bytes(data[off["ts_us"] : off["ts_us"] + 4], "little") == blob.ts_us
    assert layout.AREA_BASE == layout.STORE_BASE + layout.SLOTS * layout.SLOT_HEADER_LEN
    assert layout.AREA_BASE + layout.AREA_LEN == layout.STORE_BASE + layout.STORE_REGION <= layout.EEPROM_SIZE
    assert ModelBlob.from_bytes(data) == blob
