"""Generated files (C++ header, Python module, vectors, spec tables) match the catalogue."""

from __future__ import annotations

import shutil
import subprocess
import sys

from protocol_testing import ROOT

GENERATED = [
    "firmware/lib/core/protocol_messages.h",
    "host_sdk/porosense/protocol/_messages.py",
    "protocol/vectors/frames.json",
    "protocol/vectors/frames.txt",
    "protocol/spec.md",
]


def _check(root):
    return subprocess.run(
        [sys.executable, str(root / "protocol" / "generate.py"), "--check"], capture_output=True, text=True, timeout=120
    )


def test_generated_files_are_up_to_date():
    proc = _check(ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_check_reports_a_stale_file(tmp_path):
    """In a copy of the tree: editing the catalogue makes every generated file stale."""
    for rel in [
        "protocol/generate.py",
        "protocol/gen_spec.py",
        "protocol/gen_vectors.py",
        "protocol/messages.toml",
        *GENERATED,
    ]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / rel, tmp_path / rel)
    assert _check(tmp_path).returncode == 0
    toml = tmp_path / "protocol" / "messages.toml"
    toml.write_text(toml.read_text().replace('doc = "Liveness and clock check;', 'doc = "Liveness check;'))
    proc = _check(tmp_path)
    assert proc.returncode == 1
    stale = {line.split()[1] for line in proc.stdout.splitlines() if line.startswith("stale:")}
    assert stale == set(GENERATED) - {"protocol/vectors/frames.json", "protocol/vectors/frames.txt"}
