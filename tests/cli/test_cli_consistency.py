"""Every subcommand: --help with an example and --json; user mistakes give one line, no traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest

from porosense.cli import SUBCOMMANDS, build_parser, main


def _help(name: str) -> str:
    parser = build_parser()
    sub = parser._subparsers._group_actions[0].choices[name]  # the registered subparser
    return sub.format_help()


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_every_subcommand_has_help_example_and_json(name):
    text = _help(name)
    assert "example" in text.lower(), f"{name} --help has no example"
    assert "--json" in text, f"{name} has no --json"
    assert "%%" not in text, f"{name} --help shows a doubled percent sign"  # descriptions are not %-formatted


def test_user_mistakes_exit_with_one_line_and_no_traceback(tmp_path):
    missing = tmp_path / "absent.csv"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "porosense",
            "predict",
            "--model",
            str(tmp_path / "m.json"),
            "--data",
            str(missing),
            "--out",
            str(tmp_path / "p.csv"),
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 4 and "not found" in proc.stderr  # a model problem: exit 4
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert main(["bench", "protocol", "--size", "small", "--json"]) == 0
