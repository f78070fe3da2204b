"""The command line offers exactly the simulator's actuators (written out in cli/_args.py so
that --help does not load the simulator)."""

from porosense.cli import _args, build_parser
from porosense.sim import ACTUATORS


def test_cli_actuators_are_the_simulators():
    assert _args.ACTUATORS == ACTUATORS


def test_demo_offers_every_actuator_and_all():
    parser = build_parser()
    args = parser.parse_args(["demo", "--actuator", "all"])
    assert args.actuator == "all"
    sub = next(a for a in parser._subparsers._group_actions[0].choices["demo"]._actions if a.dest == "actuator")
    assert tuple(sub.choices) == (*ACTUATORS, "all")
