"""Every subcommand's parser follows docs/cli.md: one spelling per meaning, the same defaults, old
spellings still accepted with one deprecation line.

The parsers are walked as built (every subcommand and sub-subcommand), so a new option in another
spelling fails here rather than in a user's script.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from porosense.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]

# Commands that read recordings, and the options every one of them has (docs/cli.md, "Reading data").
DATA_COMMANDS = (
    "identify",
    "predict",
    "compare",
    "compensate",
    "report",
    "diagnose",
    "quantize",
    "verify",
    "control tune",
)
DATA_OPTIONS = (
    "--data",
    "--ts",
    "--ts-override",
    "--time-unit",
    "--resample",
    "--separator",
    "--decimal",
    "--skip-rows",
)
MODEL_COMMANDS = ("predict", "compare", "compensate", "report", "diagnose", "quantize", "export", "flash", "verify")
# Spellings that were replaced: they may only exist hidden (as deprecated aliases).
OLD_SPELLINGS = ("--save", "--inputs", "--load", "--no-progress", "--command", "--report")
# Leaf commands without a JSON result, and why.
NO_JSON = {
    "infoam design": "writes an editable design file; its content is the JSON",
    "infoam figures": "writes figures only",
}
RATE_HZ = 50.0  # the one default sample rate (the board's)
MAX_POLES = {"identify": 10, "demo": 3}  # demo states its smaller search in --help


def leaves():
    """(name, parser) of every command a user runs, 'control tune' style for nested ones."""
    out = []

    def walk(name, parser):
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            out.append((name, parser))
            return
        for child, sub in subs[0].choices.items():
            walk(f"{name} {child}".strip(), sub)

    walk("", build_parser())
    return out


LEAVES = dict(leaves())


def visible(parser) -> dict:
    """{option string: action} of the options --help shows."""
    return {o: a for a in parser._actions if a.help != argparse.SUPPRESS for o in a.option_strings}


def hidden(parser) -> dict:
    return {o: a for a in parser._actions if a.help == argparse.SUPPRESS for o in a.option_strings}


@pytest.mark.parametrize("name", sorted(LEAVES))
def test_one_spelling_per_meaning(name):
    parser = LEAVES[name]
    shown = visible(parser)
    old = [o for o in OLD_SPELLINGS if o in shown]
    assert not old, f"{name} shows the old spelling(s) {old}; docs/cli.md names the new ones"
    if name not in NO_JSON:
        assert "--json" in shown and "--json-out" in shown, f"{name}: --json (stdout) and --json-out FILE"
        legacy = name in ("identify", "diagnose") and shown["--json"].nargs == "?"  # --json FILE, deprecated
        assert shown["--json"].nargs == 0 or legacy, f"{name}: --json takes no file (that is --json-out)"
        assert "FILE" not in (shown["--json"].help or ""), f"{name}: --json's help offers a file"
    for option in ("--input", "--output"):
        if option in shown:
            assert shown[option].nargs == "+", f"{name} {option} takes COL... (space-separated)"
            assert shown[option].metavar == "COL", f"{name} {option}"
    if "--rate" in shown:
        assert float(shown["--rate"].default) == RATE_HZ, f"{name} --rate defaults to {shown['--rate'].default}"
    if "--max-poles" in shown:
        assert shown["--max-poles"].default == MAX_POLES[name]
    if "--data" in shown:
        assert shown["--data"].nargs == "+" and shown["--data"].metavar == "FILE", name
    for option, action in shown.items():
        if option.startswith("--") and option not in ("--help", "--version"):
            assert action.help, f"{name} {option} has no help text"
    for action in parser._actions:  # positional arguments other than names of things are not data
        if not action.option_strings and action.help != argparse.SUPPRESS:
            assert action.dest not in ("data", "model", "blob"), f"{name}: {action.dest} is an option, not positional"
    text = parser.format_help()
    assert "%%" not in text, f"{name} --help shows a doubled percent sign"
    assert not re.search(r"\bnan\b", text), f"{name} --help prints nan"


@pytest.mark.parametrize("name", DATA_COMMANDS)
def test_every_data_command_reads_data_the_same_way(name):
    shown = visible(LEAVES[name])
    missing = [o for o in DATA_OPTIONS if o not in shown]
    assert not missing, f"{name} lacks {missing}"
    assert shown["--time-unit"].choices == ("s", "ms", "us")


@pytest.mark.parametrize("name", MODEL_COMMANDS)
def test_models_are_named_by_an_option(name):
    assert "--model" in visible(LEAVES[name]), name


@pytest.mark.parametrize(
    "name,option",
    [("identify", "--quiet"), ("demo", "--quiet"), ("record", "--quiet")]
    + [(n, "--load-g") for n in ("simulate", "emulator", "control run", "infoam predict")],
)
def test_shared_options_where_they_apply(name, option):
    assert option in visible(LEAVES[name])


# (old argv, new argv): both parse to the same values; the old one prints one deprecation line.
DEPRECATED = [
    (
        "identify --data a.csv --input dR_0 --output s --save m.json",
        "identify --data a.csv --input dR_0 --output s --out m.json",
    ),
    (
        "diagnose --data a.csv --input u --output y --baseline wh --report d",
        "diagnose --data a.csv --input u --output y --baseline wh --out d",
    ),
    (
        "verify --port loop:// --model m.bin --data a.csv --inputs a b",
        "verify --port loop:// --model m.bin --data a.csv --input a b",
    ),
    ("simulate contractor -e step_10 --load 200", "simulate contractor -e step_10 --load-g 200"),
    ("control run --port emulator --target 5 --load 200", "control run --port emulator --target 5 --load-g 200"),
    ("infoam predict contractor --load 200", "infoam predict contractor --load-g 200"),
    ("demo --no-progress", "demo --quiet"),
    ("record --port loop:// --out r.csv --no-progress", "record --port loop:// --out r.csv --quiet"),
    ("control tune --data a.csv --command p_cmd_1", "control tune --data a.csv --input p_cmd_1"),
    ("infoam calibrate --save c.json", "infoam calibrate --out c.json"),
]


@pytest.mark.parametrize("old,new", DEPRECATED, ids=[d[0].split(" --")[0] + " " + d[0].split()[-2] for d in DEPRECATED])
def test_old_spellings_parse_to_the_new_ones_with_one_line(old, new, capsys):
    parser = build_parser()
    old_ns = vars(parser.parse_args(old.split()))
    err = capsys.readouterr().err.strip().splitlines()
    new_ns = vars(parser.parse_args(new.split()))
    assert len(err) == 1 and "is deprecated, write" in err[0] and "accepted until" in err[0], err
    assert err[0].startswith("porosense "), err
    for key, value in new_ns.items():
        if key != "func":
            assert old_ns.get(key) == value, (key, old_ns.get(key), value)


def test_old_positional_json_file_and_comma_spellings_still_work(tmp_path, capsys):
    """`export MODEL` runs; `--json FILE` and `--input A,B` are read as before; each says so once."""
    import numpy as np

    from porosense import ident
    from porosense.cli._args import columns
    from porosense.cli._data import normalise_json_args

    u = np.repeat(np.linspace(0, -50, 20), 20)
    m = ident.make_model("linear", n_poles=1, n_zeros=0).fit(
        u=u[:, None], y=0.3 * u + 0.01 * np.sin(np.arange(u.size)), ts=0.02, inputs=("dR_0",), output="strain_0"
    )
    m.save(tmp_path / "m.json")
    assert main(["export", str(tmp_path / "m.json"), "--c"]) == 0 and (tmp_path / "m.c").is_file()
    assert "the positional MODEL is deprecated, write --model MODEL" in capsys.readouterr().err
    args = build_parser().parse_args(
        ["identify", "--data", "a.csv", "--input", "a,b", "--output", "y", "--json", "r.json"]
    )
    normalise_json_args(args)
    assert args.json_out == "r.json" and args.json is False
    assert columns(args.input, "input", args) == ["a", "b"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--json FILE is deprecated" in err[0] and "--input A,B is deprecated" in err[1]


def test_docs_list_every_old_spelling_the_parsers_accept():
    doc = (ROOT / "docs" / "cli.md").read_text()
    for name, parser in LEAVES.items():
        for option in hidden(parser):
            assert f"{option}" in doc, f"{name} accepts {option} but docs/cli.md does not list it"
