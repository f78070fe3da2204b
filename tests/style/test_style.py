"""The repository's code style, checked as part of the suite: ruff (lint and format, settings
in ruff.toml) over every Python file, clang-format (.clang-format) over the firmware, its host
tests and the simboard harness. A failure lists the files and the command that fixes them."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# Generated files keep the generator's layout.
GENERATED = {"firmware/lib/core/protocol_messages.h", "firmware/lib/core/model_layout.h"}
C_GLOBS = (
    "firmware/*.c",
    "firmware/*.cpp",
    "firmware/*.h",
    "tools/*.c",
    "tools/*.cpp",
    "tools/*.h",
    "tests/core/*.cpp",
    "tests/core/*.h",
    "host_sdk/porosense/firmware/programs/*.cpp",
)


def _ruff(*args: str) -> subprocess.CompletedProcess:
    exe = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if exe is None:
        pytest.fail("ruff is not installed: run tools/bootstrap.sh (it is pinned in host_sdk/requirements.lock)")
    return subprocess.run([exe, *args], cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_ruff_lint_passes():
    proc = _ruff("check", "--no-cache", ".")
    assert proc.returncode == 0, f"ruff check found problems (fix: ruff check --fix .):\n{proc.stdout[-4000:]}"


def test_ruff_format_is_applied():
    proc = _ruff("format", "--no-cache", "--check", ".")
    assert proc.returncode == 0, f"files not formatted (fix: ruff format .):\n{proc.stdout[-4000:]}"


def test_clang_format_is_applied():
    exe = shutil.which("clang-format")
    if exe is None:
        pytest.fail("clang-format is not installed: run tools/bootstrap.sh (Debian package clang-format)")
    listed = subprocess.run(["git", "ls-files", *C_GLOBS], cwd=ROOT, capture_output=True, text=True, check=True)
    files = [f for f in listed.stdout.split() if f not in GENERATED]
    assert len(files) > 50, f"only {len(files)} C/C++ files found: is this a git checkout?"
    proc = subprocess.run([exe, "--dry-run", "--Werror", *files], cwd=ROOT, capture_output=True, text=True, timeout=300)
    bad = sorted({line.split(":")[0] for line in proc.stderr.splitlines() if ": error:" in line})
    assert proc.returncode == 0, f"{len(bad)} files not formatted (fix: clang-format -i FILE): {bad[:20]}"


def test_pre_commit_hooks_run_the_suites_checks():
    """.pre-commit-config.yaml runs the same tools with the same settings as this folder's tests,
    and every tool it names is where it says (the pinned .venv or the Debian package)."""
    config = (ROOT / ".pre-commit-config.yaml").read_text()
    entries = [line.split("entry:", 1)[1].split() for line in config.splitlines() if "entry:" in line]
    tools = {Path(e[0]).name for e in entries}
    assert {"ruff", "clang-format", "lint-imports", "mypy"} <= tools, tools
    for entry in entries:
        exe = ROOT / entry[0] if "/" in entry[0] else shutil.which(entry[0])
        assert exe and Path(exe).exists(), f"pre-commit hook tool missing: {entry[0]}"
    # The clang-format hook covers the files the suite checks (C_GLOBS), minus the generated ones.
    pattern = re.search(r"files: (\S+)", config).group(1)
    listed = subprocess.run(["git", "ls-files", *C_GLOBS], cwd=ROOT, capture_output=True, text=True, check=True)
    files = [f for f in listed.stdout.split() if f not in GENERATED]
    missed = [f for f in files if not re.match(pattern, f)]
    assert not missed, f"clang-format hook misses: {missed[:10]}"


def test_test_modules_outside_packages_have_unique_names():
    """pytest imports a test module of a folder without __init__.py under its bare name: two such
    modules of one name make the second an import error (tests/ident and tests/sim both had
    test_paper.py, and the second was never run)."""
    tests = Path(__file__).resolve().parents[1]
    seen: dict[str, list[str]] = {}
    for path in tests.rglob("*.py"):
        if not (path.parent / "__init__.py").exists() and path.name != "conftest.py":
            seen.setdefault(path.name, []).append(str(path.relative_to(tests)))
    clashes = {name: where for name, where in seen.items() if len(where) > 1}
    assert not clashes, clashes
