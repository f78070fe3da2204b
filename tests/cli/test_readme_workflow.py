"""The README's workflow runs as printed, in an empty folder, against the emulator."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .test_help_examples import EMULATOR_PORT, _port_free


def workflow_block(readme: Path) -> str:
    """The first ```sh block after the '## Workflow' heading."""
    text = readme.read_text()
    section = text[text.index("## Workflow") :]
    return re.search(r"```sh\n(.*?)```", section, re.S).group(1)


def test_workflow_block_uses_only_porosense_and_the_shell(repo_root):
    block = workflow_block(repo_root / "README.md")
    commands = [ln for ln in block.replace("\\\n", " ").splitlines() if ln.strip()]
    assert commands[0].startswith("porosense emulator") and commands[-1].startswith("kill")
    assert all(c.startswith("porosense ") for c in commands[:-1])


@pytest.mark.slow
@pytest.mark.xdist_group("help_examples")  # shares the emulator's port with the --help examples
def test_readme_workflow_runs_as_printed(repo_root, tmp_path):
    if not _port_free(EMULATOR_PORT):
        pytest.skip(f"port {EMULATOR_PORT} is in use: the README's emulator needs it")
    block = workflow_block(repo_root / "README.md")
    script = "set -e\ntrap 'kill $(jobs -p) 2>/dev/null || true' EXIT\n" + block
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    proc = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert "identical" in proc.stdout  # verify: every replayed estimate equals the reference
    report = json.loads((tmp_path / "report.json").read_text())
    fits = {r["output"]: r for r in report["results"]}
    print("identify report outputs:", list(fits))
    for path in (
        "pred.png",
        "report/report.html",
        "diagnosis.json",
        "diag/summary.md",
        "model.c",
        "model_tf.json",
        "model.bin",
        "quant.json",
    ):
        assert (tmp_path / path).exists(), path
    fit = re.search(r"strain_0: fit (-?[\d.]+) %", proc.stdout)
    print("predict on step_40:", fit.group(0))
    assert float(fit.group(1)) > 60.0  # a 2-pole model of the contractor reconstructs the strain
