"""What a condition column is: another channel's command (cross_coupling tests it) or a measured
condition (load_dependence tests it), stated on the record or read by ``diagnose`` from units."""

from __future__ import annotations

import numpy as np
import pytest

from porosense.cli.diagnose import _column_kinds
from porosense.diagnose import Record
from porosense.errors import InputError


class _Table:
    def __init__(self, units):
        self.units = units


def test_units_tell_a_command_from_a_condition():
    # porosense's own column names carry their units (p_cmd_* kPa, load_g g, dR_* %)
    kinds = _column_kinds(["p_cmd_1", "load_g", "dR_1"], ["p_cmd_0"], [_Table({})])
    assert kinds == {"p_cmd_1": "input", "load_g": "condition", "dR_1": "condition"}
    # a stated unit wins; a column without any unit is left to both causes
    kinds = _column_kinds(["weight", "other"], ["dR_0"], [_Table({"weight": "g", "other": "percent"})])
    assert kinds == {"weight": "condition", "other": "input"}
    assert _column_kinds(["x"], ["u"], [_Table({})]) == {}


def test_a_kind_must_name_a_condition_column():
    n = 60
    with pytest.raises(InputError, match="column kinds"):
        Record(np.zeros((n, 1)), np.zeros(n), np.zeros(n), 0.1, {"load_g": np.zeros(n)}, {"load_g": "load"})
    with pytest.raises(InputError, match="column kinds"):
        Record(np.zeros((n, 1)), np.zeros(n), np.zeros(n), 0.1, {}, {"load_g": "condition"})


def test_a_stated_condition_is_not_a_leak():
    """A load that leaks additively into the output (a column the model does not use): stated a
    condition, cross_coupling does not test it and load_dependence does; unstated, both do."""
    from porosense.diagnose import diagnose

    rng = np.random.default_rng(7)
    ts, n = 0.05, 1500

    def record(seed):
        r = np.random.default_rng(seed)
        u = np.repeat(r.uniform(-1, 1, n // 50), 50)
        load = np.repeat(r.uniform(0, 1, n // 100), 100)
        y = np.convolve(u, 0.2 * 0.8 ** np.arange(30))[:n] + 0.5 * np.convolve(load, 0.1 * 0.9 ** np.arange(60))[:n]
        yhat = np.convolve(u, 0.2 * 0.8 ** np.arange(30))[:n]
        return u, y + 0.01 * rng.standard_normal(n), yhat, load

    parts = [record(s) for s in (1, 2, 3)]

    def run(kinds):
        recs = [Record(u, y, yh, ts, {"load_g": c}, kinds) for u, y, yh, c in parts]
        return diagnose(recs[:2], recs[2:])

    stated = run({"load_g": "condition"})
    assert stated.finding("cross_coupling").statistic.startswith("F(residual ~ filtered unused input)")
    assert not stated.finding("cross_coupling").found
    assert "load_g" in stated.finding("load_dependence").statistic
    unstated = run({})
    assert "load_g" in unstated.finding("cross_coupling").statistic
