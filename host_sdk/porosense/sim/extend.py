"""Extending a calibrated simulator by one named cause, fitted to measurements.

The loop of diagnosis with the simulator as the model: a parameter file (``porosense
calibrate``) misses something, diagnosis names a cause, and :func:`extend` adds that cause to
the file with its parameters fitted (least squares, the same records) and measures the gain on
held-out records (fit of dR and of every measured output, extended against calibrated, on the
same samples). The extended file is a parameter file with an ``effects`` entry
(porosense.sim.effects) that ``porosense simulate --params`` runs.

Causes and what extends the simulator for them:

- ``drift``, ``time_delay``, ``saturation``, ``slow_relaxation``, ``cross_coupling``: the named
  effect of porosense.sim.effects with its parameters fitted;
- ``static_nonlinearity``: the contact law's shape refitted (scale, exponent, largest drop);
- ``hysteresis``: the contact kinetics refitted (formation, breaking, instantaneous share);
- ``unmodelled_dynamics``: the creep and relaxation time constants and gains refitted;
- ``load_dependence``: the simulation takes the load during each record from the recording's
  load column (:data:`LOAD_COLUMN`, g; porosense.sim.effects.MEASURED), times a fitted
  ``factor`` (simulated load per measured load, 0..5): the extended file says which column and
  unit, ``simulate --params FILE --replay REC`` reads that column of REC (a record without it is
  refused in one line), and its held-out gain is measured as every other's. The gain of the
  factor itself is measured too: ``gain_unit_factor`` is the held-out gain with the load taken
  as measured (factor 1), on the same samples.

``periodic_disturbance`` and ``outliers`` disturb the measurement, not the physics:
:func:`extend` refuses them.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from porosense.dsp.blas import single_threaded
from porosense.dsp.metrics import fit_percent
from porosense.errors import InputError
from porosense.sim.calibrate import simulate_record
from porosense.sim.effects import MEASURED, resolve_effects
from porosense.sim.params import Physics

#: effect parameters fitted per cause: (name, lower, upper, start)
EFFECT_FITS = {
    "drift": (("rate_pct_per_min", -10.0, 10.0, 0.0),),
    "time_delay": (("delay_s", 0.0, 2.0, 0.1),),
    "saturation": (("low_V", 0.0, 4.0, 1.0),),
    "slow_relaxation": (("tau_s", 5.0, 200.0, 25.0), ("gain", 0.0, 0.5, 0.05)),
    "cross_coupling": (("gain", 0.0, 0.6, 0.1),),
}
#: physics fields refitted per cause: (stage, field), each as a factor of its value (0.2..5)
PHYSICS_FITS = {
    "static_nonlinearity": (("piezo", "contact_strain"), ("piezo", "contact_exponent"), ("piezo", "floor_pct")),
    "hysteresis": (("piezo", "form_s"), ("piezo", "break_s"), ("piezo", "instant_share")),
    "unmodelled_dynamics": (("foam", "creep_tau_s"), ("piezo", "relax_s"), ("piezo", "relax_gain")),
}
NOT_PHYSICS = {
    "periodic_disturbance": "a disturbance of the measurement, not of the physics",
    "outliers": "a disturbance of the measurement, not of the physics",
}
#: the recording's load column (g) the load_dependence extension runs on (porosense.sim.experiment
#: writes it; diagnosis tests it, porosense.diagnose.extensions.SIM_LOAD_COLUMN)
LOAD_COLUMN = MEASURED["load_dependence"]["column"]
#: the load_dependence extension's factor on the measured load: (lower, upper, start)
LOAD_FACTOR = (0.0, 5.0, 1.0)
FACTOR_GRID = 41  # grid points of the factor's search (steps of 0.125)
EXTENSIBLE = tuple(EFFECT_FITS) + tuple(PHYSICS_FITS) + ("load_dependence",)


def load_params(path) -> tuple[Physics, dict]:
    """(physics, effects) of a parameter file, extended or not."""
    physics = Physics.load(path)
    effects = json.loads(Path(path).read_text()).get("effects") or {}
    return physics, resolve_effects(effects)


@dataclass
class Extension:
    """An extended simulator and its measured gain (fit points, held-out records)."""

    cause: str
    physics: Physics
    effects: dict
    fitted: dict  # the parameters fitted, name -> value
    fit_calibrated: dict  # held-out record -> column -> fit (%)
    fit_extended: dict
    gain: float = field(default=float("nan"))  # mean fit points gained over held-out columns
    gain_estimation: float = field(default=float("nan"))  # the same over the records it was fitted on
    #: load_dependence: the held-out gain with the load as measured (factor 1), fit points
    gain_unit_factor: float | None = None
    #: load_dependence: the fitted factor's cost reduction against factor 1 on estimation records
    #: left out of its fit (%, mean over records; > 0 keeps the factor, else factor 1)
    factor_cross_validated: float | None = None

    def to_dict(self) -> dict:
        out = {
            "cause": self.cause,
            "fitted": self.fitted,
            "effects": self.effects,
            "fit_calibrated": self.fit_calibrated,
            "fit_extended": self.fit_extended,
            "gain": self.gain,
            "gain_estimation": self.gain_estimation,
        }
        if self.gain_unit_factor is not None:
            out["gain_unit_factor"] = self.gain_unit_factor
        if self.factor_cross_validated is not None:
            out["factor_cross_validated"] = self.factor_cross_validated
        return out

    def save(self, path) -> Path:
        """The extended parameter file (``porosense simulate --params`` runs it)."""
        return self.physics.save(path, effects=self.effects, extension=self.to_dict())

    def __str__(self) -> str:
        fitted = ", ".join(f"{k} {v:.4g}" for k, v in self.fitted.items())
        text = f"extended by {self.cause} ({fitted}): held-out gain {self.gain:+.2f} fit points"
        if self.factor_cross_validated is not None:
            text += f"; the factor cuts the cost of records left out of its fit by {self.factor_cross_validated:+.1f} %"
        if self.gain_unit_factor is not None:
            text += f" ({self.gain_unit_factor:+.2f} held out with the load as measured)"
        return text


def _fits(actuator, physics, effects, records) -> dict:
    out = {}
    for r in records:
        sim = simulate_record(actuator, physics, r, effects=effects or None)
        cols = {f"dR_{c}": fit_percent(r.dr[:, c], sim[f"dR_{c}"]) for c in range(r.dr.shape[1])}
        cols.update({k: fit_percent(v, sim[k]) for k, v in r.outputs.items()})
        out[r.name] = cols
    return out


def _clip_voltage(actuator, physics, records) -> float:
    """The divider voltage (V) of the lowest dR the records show, on the simulator's R0."""
    from porosense.sim.electronics import divider_voltage

    r0 = float(simulate_record(actuator, physics, records[0])["R_0"][0])
    lowest = min(float(np.min(r.dr)) for r in records)
    return float(divider_voltage(r0 * (1.0 + lowest / 100.0), physics.electronics))


def _mean(fits: dict) -> float:
    return float(np.mean([v for cols in fits.values() for v in cols.values()]))


@single_threaded
def extend(actuator: str, physics: Physics, cause: str, estimation, held_out, *, effects=None, max_nfev: int = 40):
    """Add ``cause`` to a calibrated simulator, fitted on ``estimation`` records, scored on ``held_out``.

    Parameters
    ----------
    actuator : str
        'contractor', 'bending' or '3dof'.
    physics : Physics
        The calibrated parameters (porosense.sim.calibrate).
    cause : str
        One of :data:`EXTENSIBLE`.
    estimation, held_out : list of porosense.sim.calibrate.ActuatorRecord
        Records the extension is fitted on and the ones its gain is measured on; for
        ``load_dependence`` every one carries its measured load (``load_g``, g).
    effects : dict, optional
        Effects the parameter file carries already (kept).
    max_nfev : int
        Residual evaluations of the fit.

    Returns
    -------
    Extension
        The extended parameters and effects, the fitted values, the held-out fits (%) of both
        simulators per record and column, the mean gain on them and on the estimation records
        (fit points).

    Raises
    ------
    InputError
        A cause that does not extend the simulator, or ``load_dependence`` on a record without
        its load.
    """
    if cause in NOT_PHYSICS:
        raise InputError(f"{cause} cannot extend the simulator: {NOT_PHYSICS[cause]}")
    if cause not in EXTENSIBLE:
        raise InputError(f"unknown cause '{cause}' (extensible: {', '.join(EXTENSIBLE)})")
    base_effects = resolve_effects(effects or {})
    if cause == "load_dependence":
        bare = [r.name or "(unnamed)" for r in list(estimation) + list(held_out) if r.load_g is None]
        if bare:
            raise InputError(
                f"load_dependence extends the simulator with the load during each record: "
                f"{bare[0]} has no load column '{LOAD_COLUMN}' (g)"
            )
        spec = (("factor",) + LOAD_FACTOR,)
        lo, hi, x0 = (np.array([s[i] for s in spec]) for i in (1, 2, 3))
        others = {k: v for k, v in base_effects.items() if k != "load_dependence"}

        def build(theta):
            measured = {**MEASURED["load_dependence"], "factor": float(theta[0])}
            return physics, {**others, "load_dependence": measured}

    elif cause in EFFECT_FITS:
        spec = EFFECT_FITS[cause]
        lo, hi, x0 = (np.array([s[i] for s in spec]) for i in (1, 2, 3))

        def build(theta):
            return physics, {
                **base_effects,
                cause: {**base_effects.get(cause, {}), **dict(zip([s[0] for s in spec], theta))},
            }

    else:
        spec = PHYSICS_FITS[cause]
        lo, hi, x0 = np.full(len(spec), math.log(0.2)), np.full(len(spec), math.log(5.0)), np.zeros(len(spec))

        def build(theta):
            stages: dict = {}
            for (stage, name), lf in zip(spec, theta):
                value = getattr(getattr(physics, stage), name)
                k = math.exp(lf)
                value = tuple(v * k for v in value) if isinstance(value, tuple) else value * k
                if name == "instant_share":
                    value = min(value, 1.0)
                if name == "floor_pct":
                    value = min(value, 99.0)
                stages.setdefault(stage, {})[name] = value
            return physics.with_(**stages), base_effects

    scales = []
    for r in estimation:
        s = {f"dR_{c}": max(float(np.std(r.dr[:, c])), 1e-6) for c in range(r.dr.shape[1])}
        s.update({k: max(float(np.std(v)), 1e-6) for k, v in r.outputs.items()})
        scales.append((s, 1.0 / math.sqrt(r.dr.shape[0])))

    def residual(theta, subset=None):
        ph, eff = build(theta)
        out = []
        for k, (r, (s, w)) in enumerate(zip(estimation, scales)):
            if subset is not None and k not in subset:
                continue
            sim = simulate_record(actuator, ph, r, effects=eff or None)
            for c in range(r.dr.shape[1]):
                out.append(w * (sim[f"dR_{c}"] - r.dr[:, c]) / s[f"dR_{c}"])
            for k, v in r.outputs.items():
                out.append(w * (sim[k] - v) / s[k])
        return np.nan_to_num(np.concatenate(out), nan=1e3)

    unit, cross_validated = None, None
    # a delay is piecewise constant in whole samples: a grid, not a gradient
    if cause == "load_dependence":
        theta, cross_validated = _load_factor(residual, lo, hi, len(estimation), max_nfev)
        if cross_validated is not None and not cross_validated > 0.0:
            theta = np.array([1.0])  # the data do not support a factor: the load as measured
    elif cause == "time_delay":
        ts = estimation[0].ts
        grid = np.arange(0.0, hi[0] + ts / 2, ts)
        costs = [float(np.sum(residual([d]) ** 2)) for d in grid]
        theta = np.array([grid[int(np.argmin(costs))]])
    else:
        if cause == "saturation":
            # a clip has no gradient where the simulation never reaches it: start at the level the
            # records sit at (their lowest dR as a divider voltage of the calibrated R0), on a grid
            v0 = _clip_voltage(actuator, physics, estimation)
            grid = np.clip(v0 * np.linspace(0.9, 1.1, 11), lo[0] + 1e-9, hi[0] - 1e-9)
            x0 = np.array([grid[int(np.argmin([float(np.sum(residual([v]) ** 2)) for v in grid]))]])
        x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
        theta = least_squares(residual, x0, bounds=(lo, hi), max_nfev=max_nfev, diff_step=1e-3).x
    ph, eff = build(theta)
    fitted = (
        {f"{st}.{n}": math.exp(float(t)) for (st, n), t in zip(spec, theta)}
        if cause in PHYSICS_FITS
        else dict(zip([s[0] for s in spec], map(float, theta)))
    )
    before = _fits(actuator, physics, base_effects, held_out)
    after = _fits(actuator, ph, eff, held_out)
    in_sample = _mean(_fits(actuator, ph, eff, estimation)) - _mean(_fits(actuator, physics, base_effects, estimation))
    if cause == "load_dependence":
        unit = _mean(_fits(actuator, *build([1.0]), held_out)) - _mean(before)
    return Extension(
        cause, ph, eff, fitted, before, after, _mean(after) - _mean(before), in_sample, unit, cross_validated
    )


def _factor_fit(residual, lo, hi, subset, max_nfev: int) -> float:
    """The load factor of least cost on the estimation records ``subset``: a grid of
    :data:`FACTOR_GRID` points over [lo, hi], refined by least squares between the best point's
    neighbours (the cost has local minima where the simulated load moves a contact past its range)."""
    grid = np.linspace(lo[0], hi[0], FACTOR_GRID)
    costs = [float(np.sum(residual([k], subset) ** 2)) for k in grid]
    best = int(np.argmin(costs))
    a, b = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    x0 = np.clip([grid[best]], a + 1e-9, b - 1e-9)
    sol = least_squares(lambda th: residual(th, subset), x0, bounds=([a], [b]), max_nfev=max_nfev, diff_step=1e-3)
    return float(sol.x[0]) if float(np.sum(sol.fun**2)) <= costs[best] else float(grid[best])


def _load_factor(residual, lo, hi, n_records: int, max_nfev: int):
    """(the factor fitted on every estimation record, as a 1-array; its cost reduction against the
    load as measured on records left out of its fit, mean over records in %, or None with one record).

    Leave one record out: the factor is fitted on the other estimation records and its cost on
    the one left out compared with factor 1's; the mean relative cost reduction (%, > 0: the
    factor predicts records it was not fitted on better than the measured load does) decides
    whether the data support a factor."""
    theta = np.array([_factor_fit(residual, lo, hi, None, max_nfev)])
    if n_records < 2:
        return theta, None
    gains = []
    for k in range(n_records):
        f = _factor_fit(residual, lo, hi, [j for j in range(n_records) if j != k], max_nfev)
        c1 = float(np.sum(residual([1.0], [k]) ** 2))
        gains.append(100.0 * (c1 - float(np.sum(residual([f], [k]) ** 2))) / max(c1, 1e-12))
    return theta, float(np.mean(gains))


def extend_best(actuator: str, physics: Physics, causes, estimation, held_out, *, effects=None):
    """Extend the simulator by each extensible cause and keep the one that fits the estimation best.

    The choice is made on the records the extensions were fitted on, so the kept extension's
    held-out gain stays an unbiased measurement of it.

    Parameters
    ----------
    actuator : str
        'contractor', 'bending' or '3dof'.
    physics : Physics
        The calibrated parameters (porosense.sim.calibrate).
    causes : iterable of str
        Causes a diagnosis found; those outside :data:`EXTENSIBLE` are passed over.
    estimation, held_out : list of porosense.sim.calibrate.ActuatorRecord
        Records the extensions are fitted on and the ones their gains are measured on.
    effects : dict, optional
        Effects the parameter file carries already (kept).

    Returns
    -------
    best : Extension or None
        The extension with the largest gain on the estimation records (fit points); None when no
        cause extends the simulator.
    tried : list of Extension
        Every extension fitted, in the order of ``causes``.
    """
    tried = [extend(actuator, physics, c, estimation, held_out, effects=effects) for c in causes if c in EXTENSIBLE]
    return (max(tried, key=lambda e: e.gain_estimation) if tried else None), tried
