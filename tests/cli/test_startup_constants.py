"""Constants the command line writes out so that `porosense --help` loads neither the simulator
nor a solver: each must equal the value the package computes with."""

from porosense.cli import _args, build_parser
from porosense.cli import control as cli_control
from porosense.control.tuning import DEFAULT_TAU_CL_S
from porosense.sim import ACTUATORS


def _option(parser, command: str, dest: str, sub: str | None = None):
    actions = parser._subparsers._group_actions[0].choices[command]
    if sub is not None:
        actions = actions._subparsers._group_actions[0].choices[sub]
    return next(a for a in actions._actions if a.dest == dest)


def test_cli_actuators_are_the_simulators():
    assert _args.ACTUATORS == ACTUATORS
    assert tuple(_option(build_parser(), "demo", "actuator").choices) == (*ACTUATORS, "all")


def test_tau_cl_default_is_the_tuning_rules():
    assert cli_control.DEFAULT_TAU_CL_S == DEFAULT_TAU_CL_S
    assert _option(build_parser(), "control", "tau_cl", sub="tune").default == DEFAULT_TAU_CL_S


def test_help_loads_no_numerical_library():
    """`porosense --help` builds every subcommand's parser without numpy, scipy, python-control or
    matplotlib (2.0 s of CPU before, 0.2 s after; each subcommand imports what it runs)."""
    import subprocess
    import sys

    code = (
        "import sys; from porosense.cli import build_parser; build_parser(); "
        "print(' '.join(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy', 'control', 'matplotlib')))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert not loaded, f"--help imports {sorted(loaded)[:8]}"
