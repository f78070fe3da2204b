"""The paper's experiment schedules as data: timed setpoints per channel.

A :class:`Schedule` holds, for each of three channels, a list of ``(t_s, setpoint_kpa)``
changes (the setpoint holds until the next change; 0 kPa means valve closed and vented,
below 0 means pump on and valve open at that vacuum). Every schedule starts with a 5 s rest
(the device calibrates R0 there). Timings follow the paper:

- ``step_10``, ``step_20``, ``step_40``, ``step_60``: vacuum on at 5, 25, 45 s and off at 15,
  35, 55 s (10 s on / 10 s off, three cycles), end at 65 s; all channels of the actuator.
  The paper ran each in duplicate: two recordings with different seeds.
- ``staircase``: gradual staircase 0 -> -10 -> -20 -> -40 -> -60 kPa and back, ramps of
  2 kPa/s (1 kPa every 0.5 s), 10 s holds at -20, -40, -60 and on the way back at -40, -20.
- 3-DoF segment: ``sequential_L`` (L = 10, 20, 40, 60; bare ``sequential`` = 60): 10 s pulses
  every 20 s of contractor 0, 1, 2 alone, then the pairs 01, 12, 20, then all three (one, two
  or three on at the level); ``parallel_L``: all three together, three 10 s cycles;
  ``two_level``: contractor 0 at -10, -20, -30 kPa (on at 5, 25, 45 s, off at 15, 35, 55 s)
  while contractor 1 is at -40 (5 to 35 s) then -60 kPa (45 to 65 s), end at 75 s.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from porosense.errors import InputError

N_CHANNELS = 3
LEVELS_KPA = (10, 20, 40, 60)
LOAD_CASES_G = (0.0, 200.0, 500.0)
REST_S = 5.0


@dataclass(frozen=True)
class Schedule:
    """Timed setpoints per channel.

    Attributes
    ----------
    name : str
        Schedule name (``"step_20"``, ``"staircase"``, ...).
    duration_s : float
        Total length, s.
    changes : tuple
        Per channel (3), ``((t_s, setpoint_kpa), ...)``: each setpoint (kPa, 0 vented, < 0 pump on
        at that vacuum) holds from its time (s) until the next change.
    description : str
        One line in words.
    """

    name: str
    duration_s: float
    changes: tuple
    description: str = ""

    def setpoints(self, t) -> np.ndarray:
        """The commanded vacuum at given times.

        Parameters
        ----------
        t : array_like
            Times, s.

        Returns
        -------
        ndarray, shape (N, 3)
            Setpoint per channel, kPa (0 vented, < 0 pump on).
        """
        t = np.asarray(t, dtype=float)
        out = np.zeros((t.size, N_CHANNELS))
        for c, changes in enumerate(self.changes):
            if not changes:
                continue
            times = np.array([tc for tc, _ in changes])
            values = np.array([v for _, v in changes], dtype=float)
            idx = np.searchsorted(times, t, side="right") - 1
            out[:, c] = np.where(idx >= 0, values[np.clip(idx, 0, None)], 0.0)
        return out

    def actuation(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Setpoints, pumps and valves at given times (pump and valve on wherever the setpoint is < 0).

        Parameters
        ----------
        t : array_like
            Times, s.

        Returns
        -------
        setpoint_kpa : ndarray, shape (N, 3)
            kPa.
        pump, valve : ndarray of bool, shape (N, 3)
            On or off.
        """
        sp = self.setpoints(t)
        on = sp < 0.0
        return sp, on, on.copy()

    def times(self, rate_hz: float) -> np.ndarray:
        """Sample times from 0 to the end.

        Parameters
        ----------
        rate_hz : float
            Sample rate, Hz.

        Returns
        -------
        ndarray
            Times, s.
        """
        return np.arange(int(round(self.duration_s * rate_hz))) / float(rate_hz)

    def channels_used(self) -> list[int]:
        """The channels the schedule ever evacuates.

        Returns
        -------
        list of int
            Channel indices, 0..2.
        """
        return [c for c, ch in enumerate(self.changes) if any(v < 0 for _, v in ch)]

    def to_dict(self) -> dict:
        """The schedule as a plain dict.

        Returns
        -------
        dict
            ``name``, ``duration_s`` (s), ``description`` and ``changes`` ([t s, kPa] per channel).
        """
        return {
            "name": self.name,
            "duration_s": self.duration_s,
            "description": self.description,
            "changes": [[list(x) for x in ch] for ch in self.changes],
        }

    @classmethod
    def from_dict(cls, d: dict) -> Schedule:
        """A schedule from :meth:`to_dict` output.

        Parameters
        ----------
        d : dict
            ``name``, ``duration_s``, ``changes`` and optionally ``description``.

        Returns
        -------
        Schedule
            The schedule.

        Raises
        ------
        InputError
            A field missing or malformed.
        """
        try:
            changes = tuple(tuple((float(t), float(v)) for t, v in ch) for ch in d["changes"])
            return cls(str(d["name"]), float(d["duration_s"]), changes, str(d.get("description", "")))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"malformed schedule: {exc}") from None

    def to_json(self) -> str:
        """The schedule as JSON text.

        Returns
        -------
        str
            :meth:`to_dict` in JSON.
        """
        return json.dumps(self.to_dict())

    def plot(self, ax=None):
        """Step plot of the setpoints of the channels used.

        Parameters
        ----------
        ax : matplotlib Axes or None
            Where to draw (None: a new figure).

        Returns
        -------
        matplotlib Axes
            Setpoint (kPa) against time (s).
        """
        import matplotlib.pyplot as plt

        ax = ax or plt.subplots(figsize=(8, 2.5))[1]
        t = self.times(20.0)
        sp = self.setpoints(t)
        for c in self.channels_used():
            ax.step(t, sp[:, c], where="post", label=f"channel {c}")
        ax.set_xlabel("t [s]"), ax.set_ylabel("setpoint [kPa]"), ax.set_title(self.name)
        ax.legend(loc="best", fontsize="small")
        return ax


def _pulses(level: float, ons, offs) -> list:
    ch = [(0.0, 0.0)]
    for a, b in zip(ons, offs):
        ch += [(float(a), -float(level)), (float(b), 0.0)]
    return ch


def _step(level: int, channels=(0, 1, 2)) -> Schedule:
    ch = _pulses(level, (5, 25, 45), (15, 35, 55))
    changes = tuple(tuple(ch) if c in channels else ((0.0, 0.0),) for c in range(N_CHANNELS))
    return Schedule(f"step_{level}", 65.0, changes, f"-{level} kPa, 10 s on / 10 s off, three cycles after 5 s rest")


def _staircase() -> Schedule:
    ch = [(0.0, 0.0)]
    t, level = REST_S, 0.0
    holds = {-20.0: 10.0, -40.0: 10.0, -60.0: 10.0}
    path = [-10.0, -20.0, -40.0, -60.0, -40.0, -20.0, -10.0, 0.0]
    for target in path:
        direction = -1.0 if target < level else 1.0
        while level != target:
            level += direction
            ch.append((t, level))
            t += 0.5  # 2 kPa/s
        if target in holds:
            t += holds[target]
    duration = t + 10.0
    return Schedule(
        "staircase",
        duration,
        (tuple(ch), ((0.0, 0.0),), ((0.0, 0.0),)),
        "gradual staircase 0 -> -60 kPa and back at 2 kPa/s, 10 s holds at -20, -40, -60 and back at -40, -20",
    )


def _sequential(level: int) -> Schedule:
    combos = [(0,), (1,), (2,), (0, 1), (1, 2), (2, 0), (0, 1, 2)]
    chans = [[(0.0, 0.0)] for _ in range(N_CHANNELS)]
    for k, combo in enumerate(combos):
        on, off = REST_S + 20.0 * k, REST_S + 20.0 * k + 10.0
        for c in combo:
            chans[c] += [(on, -float(level)), (off, 0.0)]
    return Schedule(
        f"sequential_{level}",
        REST_S + 20.0 * len(combos),
        tuple(tuple(c) for c in chans),
        f"3-DoF: one, two, then three contractors on at -{level} kPa, 10 s pulses every 20 s",
    )


def _parallel(level: int) -> Schedule:
    s = _step(level)
    return Schedule(
        f"parallel_{level}",
        s.duration_s,
        s.changes,
        f"3-DoF: all three contractors at -{level} kPa together, 10 s on / 10 s off, three cycles",
    )


def _two_level() -> Schedule:
    a = [(0.0, 0.0), (5.0, -10.0), (15.0, 0.0), (25.0, -20.0), (35.0, 0.0), (45.0, -30.0), (55.0, 0.0)]
    b = [(0.0, 0.0), (5.0, -40.0), (35.0, 0.0), (45.0, -60.0), (65.0, 0.0)]
    return Schedule(
        "two_level",
        75.0,
        (tuple(a), tuple(b), ((0.0, 0.0),)),
        "3-DoF: contractor 0 at -10/-20/-30 kPa (on 5, 25, 45 s; off 15, 35, 55 s), "
        "contractor 1 at -40 kPa (5-35 s) and -60 kPa (45-65 s)",
    )


def experiment_names() -> list[str]:
    """Every schedule name :func:`schedule` accepts.

    Returns
    -------
    list of str
        ``step_L``, ``staircase``, ``sequential_L``, ``parallel_L`` (L = 10, 20, 40, 60 kPa),
        ``sequential``, ``parallel`` and ``two_level``.
    """
    names = [f"step_{lv}" for lv in LEVELS_KPA] + ["staircase"]
    names += [f"sequential_{lv}" for lv in LEVELS_KPA] + ["sequential"]
    names += [f"parallel_{lv}" for lv in LEVELS_KPA] + ["parallel", "two_level"]
    return names


THREE_DOF_ONLY = ("sequential", "parallel", "two_level")


def schedule(name: str) -> Schedule:
    """The schedule called ``name``.

    Parameters
    ----------
    name : str
        One of :func:`experiment_names`.

    Returns
    -------
    Schedule
        Its timed setpoints.

    Raises
    ------
    InputError
        An unknown name.
    """
    base, _, level = name.partition("_")
    if name == "staircase":
        return _staircase()
    if name == "two_level":
        return _two_level()
    if name in ("sequential", "parallel"):
        level, base = "60", name
    makers = {"step": _step, "sequential": _sequential, "parallel": _parallel}
    if base in makers and level.isdigit() and int(level) in LEVELS_KPA:
        return makers[base](int(level))
    raise InputError(f"unknown experiment '{name}' (known: {', '.join(experiment_names())})")
