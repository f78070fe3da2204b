"""The plant the controller sees: commanded vacuum (kPa below ambient) -> strain, as an FOPDT.

``y = y0 + K / (T s + 1) e^(-theta s) v`` with ``v = -p_cmd`` the commanded vacuum (kPa, >= 0),
``K`` in output units per kPa, ``T`` and ``theta`` in s. Fitted in discrete time at the data's
sample period ``Ts`` (zero-order hold, so ``y[k] = a y[k-1] + K (1 - a) v[k-1-d]``, ``a =
exp(-Ts/T)``, ``theta = d Ts``): for a fixed (T, d) the model is linear in K and in one offset
per recording, so each (T, d) is a linear least-squares problem; T is searched on a bounded
log scale per integer delay d and the pair with the smallest residual is kept (an output-error
fit: simulation, not one-step prediction, as the paper scores models).

The real plant is nonlinear (pore collapse makes the strain-vs-vacuum slope vary about 2x over
the stroke); the fitted K is the least-squares average slope over the recordings, and its spread
per recording is reported so the tuning's margin can be judged.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from porosense.errors import InputError

#: Largest dead time searched (s); the regulator and the foam respond within tenths of a second.
MAX_DEAD_TIME_S = 1.0
#: Range of time constants searched (s).
T_RANGE_S = (0.01, 30.0)


@dataclass
class Fopdt:
    """First-order plus dead time from commanded vacuum to output.

    Attributes
    ----------
    K : float
        Gain, output units per kPa of vacuum.
    T : float
        Time constant, s.
    theta : float
        Dead time, s (a whole number of samples).
    ts : float
        Sample period of the data it was fitted to, s.
    fit_percent : float
        NRMSE fit of its simulation over all recordings, % (nan when not fitted).
    gain_range : tuple of float
        (min, max) of the gain fitted to each recording alone, output units per kPa.
    output_unit : str
        The output's unit (e.g. ``"%"`` strain), for printing.
    extra : dict
        Fit details (``"offsets"``: output at zero vacuum per recording, output units).
    """

    K: float
    T: float
    theta: float
    ts: float
    fit_percent: float = float("nan")
    gain_range: tuple = (float("nan"), float("nan"))
    output_unit: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def delay_samples(self) -> int:
        return int(round(self.theta / self.ts))

    def simulate(self, vacuum_kpa, y0: float = 0.0) -> np.ndarray:
        """The plant's output for a vacuum command sampled at ``ts``, from rest.

        Parameters
        ----------
        vacuum_kpa : array_like
            Commanded vacuum, kPa below ambient (>= 0), one value per sample.
        y0 : float
            Output at zero vacuum, output units.

        Returns
        -------
        ndarray
            Output, output units.
        """
        return y0 + self.K * _unit_response(np.asarray(vacuum_kpa, dtype=float), self.T, self.delay_samples, self.ts)

    def to_control(self):
        """The discrete-time transfer function from vacuum to output (python-control).

        Returns
        -------
        control.TransferFunction
            K (1 - a) z^-(d+1) / (1 - a z^-1), a = exp(-ts/T), sample time ``ts`` s.
        """
        import control

        a = math.exp(-self.ts / self.T)
        den = np.zeros(self.delay_samples + 2)
        den[0], den[1] = 1.0, -a
        return control.tf([self.K * (1.0 - a)], den, self.ts)

    def to_dict(self) -> dict:
        """The fields as a plain dict, with ``delay_samples``.

        Returns
        -------
        dict
            JSON-ready.
        """
        d = asdict(self)
        d["gain_range"] = list(self.gain_range)
        d["delay_samples"] = self.delay_samples
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Fopdt:
        """The plant from :meth:`to_dict` output (a gains file's ``plant``).

        Parameters
        ----------
        d : dict
            ``K``, ``T``, ``theta``, ``ts`` and optionally ``fit_percent``, ``gain_range``,
            ``output_unit``.

        Returns
        -------
        Fopdt
            The plant.

        Raises
        ------
        InputError
            A field missing or not a number.
        """
        try:
            return cls(
                float(d["K"]),
                float(d["T"]),
                float(d["theta"]),
                float(d["ts"]),
                float(d.get("fit_percent", "nan")),
                tuple(d.get("gain_range", (math.nan, math.nan))),
                str(d.get("output_unit", "")),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"malformed plant model: {exc}") from None

    def __str__(self) -> str:
        return (
            f"FOPDT K = {self.K:.4g} {self.output_unit or 'units'}/kPa (per recording "
            f"{self.gain_range[0]:.3g}..{self.gain_range[1]:.3g}), T = {self.T:.3f} s, "
            f"dead time {self.theta:.3f} s; fit {self.fit_percent:.1f} %"
        )


def _unit_response(v: np.ndarray, T: float, d: int, ts: float) -> np.ndarray:
    """Response of the unit-gain discrete FOPDT to ``v`` (zero initial state)."""
    a = math.exp(-ts / T)
    x = np.concatenate([np.zeros(d + 1), v[: max(len(v) - d - 1, 0)]])
    return lfilter([1.0 - a], [1.0, -a], x)


def _solve(vs, ys, T, d, ts):
    """Least squares of K and per-recording offsets for fixed (T, d): (K, offsets, sse).

    With one free offset per recording, each offset is its recording's mean residual, so K
    follows from the centred responses alone (the normal equations in closed form: O(N), where
    a dense least-squares solve of the N x (1 + recordings) system took most of a fit)."""
    gs = [_unit_response(v, T, d, ts) for v in vs]
    g_c = [g - g.mean() for g in gs]
    y_c = [y - y.mean() for y in ys]
    gg = sum(float(g @ g) for g in g_c)
    gy = sum(float(g @ y) for g, y in zip(g_c, y_c))
    K = gy / gg if gg > 0 else 0.0  # a response that never moves leaves K undetermined: 0, as lstsq's min-norm
    offsets = np.array([float(y.mean() - K * g.mean()) for g, y in zip(gs, ys)])
    sse = sum(float(r @ r) for r in (y - K * g for g, y in zip(g_c, y_c)))
    return K, offsets, sse


def _fit_one(vs, ys, ts):
    best = None
    for d in range(int(MAX_DEAD_TIME_S / ts) + 1):
        res = minimize_scalar(
            lambda lt: _solve(vs, ys, math.exp(lt), d, ts)[2],
            bounds=tuple(math.log(x) for x in T_RANGE_S),
            method="bounded",
            options={"xatol": 1e-3},
        )
        T = math.exp(res.x)
        K, off, sse = _solve(vs, ys, T, d, ts)
        if best is None or sse < best[3]:
            best = (K, T, d, sse, off)
        elif sse > 1.5 * best[3]:
            break  # past the best delay: the residual only grows with more delay
    return best


def fit_fopdt(vacuum_kpa, outputs, ts: float, *, output_unit: str = "") -> Fopdt:
    """Fit one FOPDT to recordings (output-error fit, see the module notes).

    Each recording gets its own offset (the output at zero vacuum, e.g. a load's stretch).

    Parameters
    ----------
    vacuum_kpa : list of array_like
        Per recording, the commanded vacuum, kPa below ambient (>= 0), 1-D.
    outputs : list of array_like
        Per recording, the output (in its unit), the same length as its command.
    ts : float
        Sample period, s (> 0).
    output_unit : str
        The output's unit, kept on the result for printing.

    Returns
    -------
    Fopdt
        The fitted plant, its fit % and the per-recording gain range.

    Raises
    ------
    InputError
        Mismatched lengths, a sample period <= 0, NaN or inf, a command that never changes, or a
        fitted gain that is not positive.
    """
    vs = [np.asarray(v, dtype=float).ravel() for v in vacuum_kpa]
    ys = [np.asarray(y, dtype=float).ravel() for y in outputs]
    if not vs or len(vs) != len(ys) or any(len(v) != len(y) for v, y in zip(vs, ys)):
        raise InputError("each recording needs a command and an output of the same length")
    if ts <= 0 or not math.isfinite(ts):
        raise InputError(f"sample period {ts} s must be positive")
    if not any(np.ptp(v) > 0 for v in vs):
        raise InputError("the commanded pressure never changes in these recordings: nothing to identify")
    if not all(np.all(np.isfinite(v)) and np.all(np.isfinite(y)) for v, y in zip(vs, ys)):
        raise InputError("the command or the output holds NaN or inf")
    K, T, d, sse, offsets = _fit_one(vs, ys, ts)
    gains = [_fit_one([v], [y], ts)[0] for v, y in zip(vs, ys) if np.ptp(v) > 0]
    y_all = np.concatenate(ys)
    dev = float(np.sum((y_all - y_all.mean()) ** 2))
    fit = 100.0 * (1.0 - math.sqrt(sse / dev)) if dev > 0 else float("nan")
    if not K > 0:
        raise InputError(
            f"the fitted gain {K:.3g} is not positive: more vacuum must give more output "
            "(check the command column and its sign)"
        )
    return Fopdt(
        float(K),
        float(T),
        d * ts,
        float(ts),
        fit,
        (float(min(gains)), float(max(gains))),
        output_unit,
        {"offsets": [float(o) for o in offsets]},
    )
