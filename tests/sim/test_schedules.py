"""The paper's schedules as data, with exact timings."""

import numpy as np
import pytest

from porosense.errors import InputError
from porosense.sim import Schedule, experiment_names, run_experiment, schedule


def edges(sched, channel=0, rate=100.0):
    t = sched.times(rate)
    sp = sched.setpoints(t)[:, channel]
    change = np.flatnonzero(np.diff(sp)) + 1
    return [(round(t[k], 2), sp[k]) for k in change]


@pytest.mark.parametrize("level", (10, 20, 40, 60))
def test_steps_are_10_s_on_10_s_off_three_cycles(level):
    s = schedule(f"step_{level}")
    assert s.duration_s == 65.0
    assert edges(s) == [(5.0, -level), (15.0, 0.0), (25.0, -level), (35.0, 0.0), (45.0, -level), (55.0, 0.0)]


def test_staircase_ramps_at_2_kpa_per_s_with_10_s_holds():
    s = schedule("staircase")
    t = s.times(100.0)
    sp = s.setpoints(t)[:, 0]
    assert sp.min() == -60.0 and sp[0] == 0.0 and sp[-1] == 0.0
    assert np.max(np.abs(np.diff(sp))) == 1.0  # 1 kPa increments
    for level, holds in ((-20.0, 2), (-40.0, 2), (-60.0, 1)):
        at = np.r_[0, (sp == level).astype(int), 0]
        runs = np.flatnonzero(np.diff(at) == -1) - np.flatnonzero(np.diff(at) == 1)
        assert sorted(runs)[-holds:] == [1050] * holds  # 10 s hold + the 0.5 s ramp step
    ramp = np.flatnonzero(np.diff(sp))
    assert np.median(np.diff(t[ramp + 1])) == pytest.approx(0.5)


def test_two_level_pattern():
    s = schedule("two_level")
    assert edges(s, 0) == [(5.0, -10.0), (15.0, 0.0), (25.0, -20.0), (35.0, 0.0), (45.0, -30.0), (55.0, 0.0)]
    assert edges(s, 1) == [(5.0, -40.0), (35.0, 0.0), (45.0, -60.0), (65.0, 0.0)]
    assert edges(s, 2) == []


def test_sequential_runs_one_two_then_three_contractors():
    s = schedule("sequential_20")
    on = s.setpoints(s.times(10.0)) < 0
    counts = [int(on[int(10 * (10 + 20 * k))].sum()) for k in range(7)]
    assert counts == [1, 1, 1, 2, 2, 2, 3]
    assert schedule("sequential").name == "sequential_60"


def test_schedule_is_data_and_round_trips():
    for name in experiment_names():
        s = schedule(name)
        assert Schedule.from_dict(s.to_dict()) == s


def test_unknown_and_misapplied_experiments():
    with pytest.raises(InputError, match="unknown experiment 'step_30'"):
        schedule("step_30")
    with pytest.raises(InputError, match="3dof"):
        run_experiment("contractor", "two_level")
