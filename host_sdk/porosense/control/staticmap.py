"""The steady-state output-vs-vacuum map and its inverse: the open-loop way to ask for a strain.

What users do without feedback: hold a few vacuum levels on the unloaded actuator, note the
settled strain of each, and to get a strain command the vacuum the map gives for it
(linear interpolation between the measured levels). :func:`static_map` reads those levels from
recordings made of holds (the paper's steps and staircase, or any schedule of holds): for each
hold of at least ``min_hold_s`` it averages the output over the hold's last ``tail`` share.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from porosense.errors import InputError

MIN_HOLD_S = 3.0
TAIL = 0.25


@dataclass
class StaticMap:
    """The settled output at each held vacuum level.

    Attributes
    ----------
    vacuum_kpa : ndarray
        Held vacuum levels, kPa below ambient, increasing.
    output : ndarray
        Settled output at each level, output units.
    """

    vacuum_kpa: np.ndarray
    output: np.ndarray

    def vacuum_for(self, target) -> np.ndarray:
        """The vacuum the map gives for a target output (the open-loop command).

        Clipped to the measured range: beyond the largest level the map knows nothing.

        Parameters
        ----------
        target : float or array_like
            Target output, output units.

        Returns
        -------
        ndarray
            Vacuum, kPa below ambient.
        """
        out = np.asarray(self.output, dtype=float)
        # The inverse needs a strictly increasing map: keep the running maximum's new highs.
        keep = np.concatenate([[True], np.diff(np.maximum.accumulate(out)) > 0])
        return np.interp(target, out[keep], np.asarray(self.vacuum_kpa)[keep])

    def output_at(self, vacuum_kpa) -> np.ndarray:
        """The settled output the map gives for a vacuum (linear between levels, clipped at the ends).

        Parameters
        ----------
        vacuum_kpa : float or array_like
            Vacuum, kPa below ambient.

        Returns
        -------
        ndarray
            Settled output, output units.
        """
        return np.interp(vacuum_kpa, self.vacuum_kpa, self.output)

    def to_dict(self) -> dict:
        """The map as lists.

        Returns
        -------
        dict
            ``vacuum_kpa`` (kPa) and ``output`` (output units).
        """
        return {"vacuum_kpa": self.vacuum_kpa.tolist(), "output": self.output.tolist()}


def hold_levels(t, vacuum_kpa, output, *, min_hold_s: float = MIN_HOLD_S, tail: float = TAIL):
    """(vacuum, settled output) of each constant-command hold of at least ``min_hold_s`` s."""
    t = np.asarray(t, dtype=float)
    v = np.asarray(vacuum_kpa, dtype=float)
    y = np.asarray(output, dtype=float)
    edges = np.flatnonzero(np.diff(v) != 0) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [len(v)]])
    out = []
    for a, b in zip(starts, ends):
        if b - a < 2 or t[b - 1] - t[a] < min_hold_s:
            continue
        k = a + int((b - a) * (1.0 - tail))
        out.append((float(v[a]), float(np.mean(y[k:b]))))
    return out


def static_map(recordings, *, min_hold_s: float = MIN_HOLD_S) -> StaticMap:
    """The static map from recordings of held vacuum levels.

    Levels within 0.5 kPa of each other are pooled (mean of their settled outputs).

    Parameters
    ----------
    recordings : list of (t, vacuum_kpa, output)
        Per recording, three equal-length arrays: time, s; commanded vacuum, kPa below ambient
        (>= 0); output, output units.
    min_hold_s : float
        Shortest hold that counts, s; the output is averaged over each hold's last quarter.

    Returns
    -------
    StaticMap
        One point per distinct level, increasing in vacuum.

    Raises
    ------
    InputError
        Fewer than two distinct levels held for ``min_hold_s``.
    """
    pts = [p for t, v, y in recordings for p in hold_levels(t, v, y, min_hold_s=min_hold_s)]
    if len({round(v * 2) for v, _ in pts}) < 2:
        raise InputError(f"the recordings hold fewer than two vacuum levels for {min_hold_s:g} s: no static map")
    pts.sort()
    levels, _outs = [], []
    for v, y in pts:
        if levels and abs(v - levels[-1][0]) < 0.5:
            levels[-1][1].append(y)
        else:
            levels.append((v, [y]))
    return StaticMap(np.array([v for v, _ in levels]), np.array([np.mean(ys) for _, ys in levels]))
