"""Calibration of the simulator from measurements (``porosense calibrate``).

Two fits, both least squares (``scipy.optimize.least_squares``, bounded, finite-difference
Jacobian):

- material (:func:`calibrate_material`): the piezoresistive law of porosense.sim.material from
  tensile tests (strain imposed, resistance measured over time). Its static curve is measured
  (``curve_strain`` / ``curve_log_r``: the settled ln(R / R0) at breakpoints spread over the
  strains seen), with the contact kinetics, the two relaxation modes and the softening on top.
  Each recording has its own R0 and a linear R0 drift (real tensile records differ by tens of
  percent between recordings and drift within one): both enter ln R linearly and are solved
  exactly inside each residual evaluation (variable projection), on the estimation samples only.
- actuator (:func:`calibrate_actuator`): the plant's foam (stiffness, collapse stress, creep),
  contact law, kinetics and relaxation from recordings of commanded vacuum, dR and, where
  present, the measured outputs (strain, curvature, angles). The print measured has no
  print-to-print variation: the calibrated file sets it to zero.

:func:`simulate_record` and :func:`simulate_material` replay a recording's inputs through
the (calibrated) simulator.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from porosense.dsp.blas import single_threaded
from porosense.dsp.metrics import fit_percent
from porosense.errors import InputError
from porosense.sim.material import ContactNetwork
from porosense.sim.params import Physics, Piezo

CURVE_POINTS = 8  # breakpoints of the measured static curve
MATERIAL_EFFECTS = ("rate_hysteresis", "relaxation", "softening", "drift")


def _fit_percent(y, yhat) -> float:
    """NRMSE fit (%) of ``yhat`` against ``y`` (porosense.dsp.metrics.fit_percent)."""
    return fit_percent(y, yhat)


# --- material ----------------------------------------------------------------------------------
@dataclass
class MaterialRecord:
    """One tensile recording: times ``t`` (s), imposed ``strain`` (fraction), resistance ``r``
    (ohm), ``mask`` the estimation samples (True) and its ``name``."""

    t: np.ndarray
    strain: np.ndarray
    r: np.ndarray
    mask: np.ndarray
    name: str = ""

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        self.strain = np.asarray(self.strain, dtype=float)
        self.r = np.asarray(self.r, dtype=float)
        self.mask = np.asarray(self.mask, dtype=bool)
        if not (self.t.size == self.strain.size == self.r.size == self.mask.size) or self.t.size < 10:
            raise InputError(f"record {self.name}: t, strain and R need the same length (at least 10 samples)")
        if not np.all(np.isfinite(self.r)) or np.any(self.r <= 0):
            raise InputError(f"record {self.name}: resistance must be finite and positive")
        if self.mask.sum() < 10:
            raise InputError(f"record {self.name}: fewer than 10 estimation samples")

    @property
    def ts(self) -> float:
        return float(np.median(np.diff(self.t)))


@dataclass
class MaterialCalibration:
    """A calibrated material law and its figures (fits of R in %)."""

    physics: Physics
    names: list
    r0_ohm: list  # each recording's R0 at t = 0 (ohm)
    drift_pct_per_min: list  # each recording's linear R0 drift (% of R0 per minute)
    fit_estimation: list  # fit of R on the estimation samples, per recording (%)
    fit_held_out: list  # fit of R on the other samples (NaN where there are none)
    ablation: dict = field(default_factory=dict)  # effect -> mean held-out fit refitted without it
    cost_evaluations: int = 0

    def to_dict(self) -> dict:
        return {
            "names": self.names,
            "r0_ohm": self.r0_ohm,
            "drift_pct_per_min": self.drift_pct_per_min,
            "fit_estimation": self.fit_estimation,
            "fit_held_out": self.fit_held_out,
            "ablation": self.ablation,
            "piezo": self.physics.to_dict()["piezo"],
        }

    def __str__(self) -> str:
        pz = self.physics.piezo
        lines = [
            f"material law: kinetics {pz.form_s:.2f} / {pz.break_s:.2f} s (instant share {pz.instant_share:.2f}), "
            f"relaxation {pz.relax_s[0]:.1f} s x {pz.relax_gain[0]:.3f}, {pz.relax_s[1]:.1f} s x {pz.relax_gain[1]:.3f}, "
            f"softening {pz.soften_fraction:.3f}",
        ]
        for k, name in enumerate(self.names):
            lines.append(
                f"  {name}: R0 {self.r0_ohm[k]:.1f} ohm, drift {self.drift_pct_per_min[k]:+.3f} %/min, "
                f"fit of R {self.fit_estimation[k]:.2f} % (estimation), {self.fit_held_out[k]:.2f} % (held out)"
            )
        for effect, fit in self.ablation.items():
            lines.append(f"  without {effect}: held-out fit {fit:.2f} %")
        return "\n".join(lines)


# parameter vector of the material law: curve values, then the dynamics
_DYN = ("instant_share", "log_form_s", "log_break_s", "log_relax0", "log_relax1", "gain0", "gain1", "soften")
_DYN_X0 = (0.5, math.log(1.0), math.log(1.0), math.log(3.0), math.log(60.0), 0.1, 0.1, 0.0)
_DYN_LO = (0.0, math.log(0.02), math.log(0.02), math.log(0.3), math.log(10.0), 0.0, 0.0, 0.0)
_DYN_HI = (1.0, math.log(300.0), math.log(300.0), math.log(30.0), math.log(2000.0), 2.0, 2.0, 0.5)


def _material_piezo(theta, curve_strain, off=()) -> Piezo:
    # the curve is 0 at the lowest strain (R0 is the settled resistance there)
    n = len(curve_strain) - 1
    curve = (0.0,) + tuple(float(v) for v in theta[:n])
    d = dict(zip(_DYN, theta[n:]))
    form = math.exp(d["log_form_s"])
    return replace(
        Piezo(),
        curve_strain=tuple(float(s) for s in curve_strain),
        curve_log_r=curve,
        instant_share=1.0 if "rate_hysteresis" in off else float(d["instant_share"]),
        form_s=form,
        break_s=form if "rate_hysteresis" in off else math.exp(d["log_break_s"]),
        relax_s=(math.exp(d["log_relax0"]), math.exp(d["log_relax1"])),
        relax_gain=(0.0, 0.0) if "relaxation" in off else (float(d["gain0"]), float(d["gain1"])),
        relax_log=True,
        soften_fraction=0.0 if "softening" in off else float(d["soften"]),
        soften_cycles=1.0,
        noise_pct=0.0,
        flicker_pct=0.0,
    )


def material_log_r(piezo: Piezo, rec: MaterialRecord) -> np.ndarray:
    """ln(R / R0) of the law for ``rec``'s strain, from rest at its first strain."""
    net = ContactNetwork(piezo, 1.0, 0.0)
    net.reset(float(rec.strain[0]))
    return np.log1p(net.run(rec.strain, rec.ts)["dR"] / 100.0)


def _baseline(rec: MaterialRecord, resid_log: np.ndarray, drift: bool) -> tuple[float, float]:
    """(ln R0, slope per s) of ln R - law on the estimation samples (least squares)."""
    m = rec.mask
    if not drift:
        return float(np.mean(resid_log[m])), 0.0
    a = np.column_stack([np.ones(m.sum()), rec.t[m] - rec.t[0]])
    coef = np.linalg.lstsq(a, resid_log[m], rcond=None)[0]
    return float(coef[0]), float(coef[1])


def _material_fit(records, off=(), max_nfev: int = 60):
    strains = np.concatenate([r.strain[r.mask] for r in records])
    lo, hi = float(np.min(strains)), float(np.max(strains))
    if not hi > lo:
        raise InputError("the strain does not change in the estimation samples: nothing to calibrate")
    curve_strain = np.linspace(lo, hi, CURVE_POINTS)
    # initial curve: the median ln R (relative to each record's start) near each breakpoint
    rel = np.concatenate([np.log(r.r[r.mask] / r.r[0]) for r in records])
    half = (hi - lo) / (CURVE_POINTS - 1)
    curve0 = []
    for s in curve_strain:
        near = np.abs(strains - s) <= half
        curve0.append(float(np.median(rel[near])) if near.any() else 0.0)
    curve0 = (np.asarray(curve0) - curve0[0])[1:]
    span = max(float(np.ptp(rel)), 0.1)
    x0 = np.r_[curve0, _DYN_X0]
    lo_b = np.r_[np.full(CURVE_POINTS - 1, -10 * span - 1), _DYN_LO]
    hi_b = np.r_[np.full(CURVE_POINTS - 1, 10 * span + 1), _DYN_HI]
    x0 = np.clip(x0, lo_b + 1e-9, hi_b - 1e-9)
    drift = "drift" not in off
    logs = [np.log(r.r) for r in records]
    weights = [1.0 / math.sqrt(r.mask.sum()) for r in records]

    def residual(theta):
        pz = _material_piezo(theta, curve_strain, off)
        out = []
        for r, lr, w in zip(records, logs, weights):
            model = material_log_r(pz, r)
            a, b = _baseline(r, lr - model, drift)
            out.append(w * (lr - model - a - b * (r.t - r.t[0]))[r.mask])
        return np.concatenate(out)

    sol = least_squares(residual, x0, bounds=(lo_b, hi_b), max_nfev=max_nfev, x_scale="jac")
    pz = _material_piezo(sol.x, curve_strain, off)
    result = []
    for r, lr in zip(records, logs):
        model = material_log_r(pz, r)
        a, b = _baseline(r, lr - model, drift)
        pred = np.exp(model + a + b * (r.t - r.t[0]))
        held = ~r.mask
        result.append(
            (
                math.exp(a),
                b * 60.0 * 100.0,
                fit_percent(r.r[r.mask], pred[r.mask]),
                fit_percent(r.r[held], pred[held]) if held.sum() > 2 else float("nan"),
            )
        )
    return pz, result, int(sol.nfev)


@single_threaded
def calibrate_material(records, *, ablation: bool = False, max_nfev: int = 60) -> MaterialCalibration:
    """Fit the piezoresistive law to tensile recordings.

    Parameters
    ----------
    records : list of MaterialRecord
        Strain (fraction) imposed, resistance (ohm) measured; each record's ``mask`` marks the
        estimation samples (the rest is held out and scored).
    ablation : bool
        Also refit with each of :data:`MATERIAL_EFFECTS` switched off and report the mean
        held-out fit without it (what each effect contributes).
    max_nfev : int
        Residual evaluations of the least-squares fit (each runs every record once).

    Returns
    -------
    MaterialCalibration
        The law (a :class:`Physics` whose piezo carries it), each record's R0 (ohm) and drift
        (% of R0 per minute), and the fits of R (%).
    """
    records = list(records)
    if not records:
        raise InputError("no tensile recording to calibrate from")
    pz, res, nfev = _material_fit(records, max_nfev=max_nfev)
    cal = MaterialCalibration(
        physics=replace(Physics(), piezo=pz).without("repeat_variation", "baseline_drift"),
        names=[r.name for r in records],
        r0_ohm=[v[0] for v in res],
        drift_pct_per_min=[v[1] for v in res],
        fit_estimation=[v[2] for v in res],
        fit_held_out=[v[3] for v in res],
        cost_evaluations=nfev,
    )
    if ablation:
        for effect in MATERIAL_EFFECTS:
            _, res_off, _ = _material_fit(records, off=(effect,), max_nfev=max_nfev)
            cal.ablation[effect] = float(np.nanmean([v[3] for v in res_off]))
    return cal


def simulate_material(physics: Physics, t, strain, r=None, estimation=None) -> dict:
    """Replay a strain series (fraction) through a calibrated law.

    R0 and its drift are those of the measured ``r`` on the ``estimation`` samples (all where
    None) when ``r`` is given, else R0 of the parameter file. Returns ``R_sim`` (ohm),
    ``dR_sim`` (% of R0) and the fits of R (%) overall and on the samples outside ``estimation``.
    """
    t = np.asarray(t, dtype=float)
    mask = np.ones(t.size, bool) if estimation is None else np.asarray(estimation, bool)
    rec = MaterialRecord(t, strain, r if r is not None else np.ones(t.size), mask, "replay")
    model = material_log_r(physics.piezo, rec)
    if r is None:
        a, b = math.log(physics.piezo.r0_ohm), 0.0
    else:
        a, b = _baseline(rec, np.log(rec.r) - model, True)
    r_sim = np.exp(model + a + b * (t - t[0]))
    out = {"R_sim": r_sim, "dR_sim": 100.0 * np.expm1(model)}
    if r is not None:
        out["fit_R"] = fit_percent(r, r_sim)
        out["fit_R_held_out"] = fit_percent(rec.r[~mask], r_sim[~mask]) if (~mask).sum() > 2 else float("nan")
    return out


# --- actuator ----------------------------------------------------------------------------------
@dataclass
class ActuatorRecord:
    """One actuator recording: commanded vacuum ``p_cmd`` (N, channels; kPa), sample period
    ``ts`` (s), measured ``dr`` (N, channels; %), measured ``outputs`` (name -> (N,)), a ``name``
    and, where the recording measured it, the load during it ``load_g`` (N,) g (what a
    ``load_dependence`` in its measured form runs on, porosense.sim.effects)."""

    p_cmd: np.ndarray
    ts: float
    dr: np.ndarray
    outputs: dict = field(default_factory=dict)
    name: str = ""
    load_g: np.ndarray | None = None

    def __post_init__(self):
        self.p_cmd = np.atleast_2d(np.asarray(self.p_cmd, dtype=float).T).T
        self.dr = np.atleast_2d(np.asarray(self.dr, dtype=float).T).T
        self.outputs = {k: np.asarray(v, dtype=float) for k, v in self.outputs.items()}
        if self.p_cmd.shape[0] != self.dr.shape[0] or self.p_cmd.shape[0] < 10:
            raise InputError(f"record {self.name}: p_cmd and dR need the same length (at least 10 samples)")
        if not np.all(np.isfinite(self.p_cmd)) or not np.all(np.isfinite(self.dr)):
            raise InputError(f"record {self.name}: p_cmd and dR must be finite")
        if self.load_g is not None:
            self.load_g = np.asarray(self.load_g, dtype=float).reshape(-1)
            if self.load_g.size != self.p_cmd.shape[0] or not np.all(np.isfinite(self.load_g)):
                raise InputError(f"record {self.name}: the load (g) needs a finite value on every sample")


def simulate_record(
    actuator: str, physics: Physics, rec: ActuatorRecord, *, porosity=None, seed: int = 0, effects=None, load_g=None
) -> dict:
    """Noiseless simulated columns (``R_c``, ``dR_c``, ``strain_c`` and the actuator's outputs)
    for the commanded vacuum of ``rec``. With ``effects`` (porosense.sim.effects) ``dR_c`` is
    the one the electronics read (delay, clipping and drift included), relative to the first
    sample, as a recording's is. ``load_g`` (N,) g: the load during the record (None: the
    record's own ``load_g`` where ``effects`` hold ``load_dependence`` in its measured form, else
    the simulator's own, porosense.sim.plant.Plant.run); that form scales it by its ``factor``.

    Raises
    ------
    InputError
        ``effects`` take the load from a column the record does not carry."""
    from porosense.sim.effects import measured_load, resolve_effects
    from porosense.sim.electronics import resistance_from_voltage
    from porosense.sim.plant import make_plant

    effects = resolve_effects(effects) if effects else effects
    measured = measured_load(effects)
    if measured is not None:
        column, factor = measured
        effects = {k: v for k, v in effects.items() if k != "load_dependence"}
        series = load_g if load_g is not None else rec.load_g
        if series is None:
            raise InputError(
                f"record {rec.name or '(unnamed)'} has no load column '{column}' (g): the parameter file's "
                "load_dependence takes the load during the record from it"
            )
        load_g = factor * np.asarray(series, dtype=float)
    plant = make_plant(actuator, porosity=porosity, physics=physics, noise=False, seed=seed, effects=effects)
    n = plant.n_channels
    sp = np.zeros((rec.p_cmd.shape[0], 3))
    sp[:, : min(n, rec.p_cmd.shape[1])] = rec.p_cmd[:, :n]
    on = sp < 0.0
    out = plant.run(rec.ts, sp, on, on.copy(), load_g=load_g)
    if effects or measured is not None:
        for c in range(n):
            r = resistance_from_voltage(out["voltage_V"][:, c], physics.electronics)
            out[f"dR_{c}"] = (r / r[0] - 1.0) * 100.0
    return out


def simulated_output(actuator: str, physics: Physics, p_cmd, ts: float, output: str, *, effects=None) -> np.ndarray:
    """One noiseless simulated column for a commanded vacuum series (what diagnosis compares).

    Parameters
    ----------
    actuator : str
        'contractor', 'bending' or '3dof'.
    physics : Physics
        The simulator's parameters (a calibrated parameter file's).
    p_cmd : array_like, shape (N,) or (N, channels)
        Commanded vacuum, kPa (<= 0 on).
    ts : float
        Sample period, s.
    output : str
        A column of :func:`simulate_record` (``dR_0``, ``strain_0``, ``curvature``, ``theta_x``, ...).
    effects : dict, optional
        Named effects (porosense.sim.effects) the parameter file carries.

    Returns
    -------
    ndarray, shape (N,)
        The column, in its unit (% for dR and strain, 1/m, deg, mm).

    Raises
    ------
    InputError
        An output the actuator's simulator does not have.
    """
    p = np.asarray(p_cmd, dtype=float)
    p = p[:, None] if p.ndim == 1 else p
    out = simulate_record(actuator, physics, ActuatorRecord(p, ts, np.zeros_like(p)), effects=effects or None)
    if output not in out:
        names = ", ".join(k for k in out if not k.startswith(("voltage", "euler", "t_", "g_")))
        raise InputError(f"the {actuator} simulator has no output '{output}' (it has {names})")
    return np.asarray(out[output], dtype=float)


# (stage, field, log scale?, lower, upper) of the actuator fit; values are factors of the start
_ACT = (
    ("foam", "solid_modulus_kpa", 0.2, 5.0),
    ("foam", "collapse_kpa_ref", 0.3, 3.0),
    ("foam", "collapse_width", 0.3, 3.0),
    ("foam", "creep", 0.2, 5.0),
    ("piezo", "contact_strain", 0.3, 3.0),
    ("piezo", "contact_exponent", 0.5, 2.0),
    ("piezo", "floor_pct", 0.7, 1.02),
    ("piezo", "instant_share", 0.1, 3.0),
    ("piezo", "form_s", 0.1, 10.0),
    ("piezo", "break_s", 0.1, 10.0),
    ("piezo", "relax_gain", 0.05, 3.0),
    ("piezo", "relax_s", 0.2, 5.0),
)
#: fitted as well where the records' loads differ (a load's share on the foam, at most 1, and the
#: contacts it holds open): with one load throughout they trade off against the unloaded physics
_LOAD_ACT = (
    ("foam", "load_share", 0.2, 5.0),
    ("piezo", "load_contact_coupling", 0.1, 10.0),
)


def piled_at_extreme(y: np.ndarray, min_count: int = 10) -> np.ndarray:
    """Samples exactly at the series' minimum or maximum when at least ``min_count`` sit there
    (a clipped reading; a continuous measurement repeats its extreme by chance only a few times)."""
    y = np.asarray(y, dtype=float)
    tol = 1e-9 * (float(np.ptp(y)) or 1.0)
    out = np.zeros(y.size, dtype=bool)
    for ext in (y.min(), y.max()):
        at = np.abs(y - ext) <= tol
        if at.sum() >= min_count:
            out |= at
    return out


def _actuator_physics(base: Physics, theta, spec=_ACT) -> Physics:
    f, pz = base.foam, base.piezo
    fv, pv = {}, {}
    for (stage, name, _, _), lf in zip(spec, theta):
        k = math.exp(lf)
        if name == "creep":
            fv["creep_tau_s"] = tuple(tau * k for tau in f.creep_tau_s)
        elif name in ("relax_gain", "relax_s"):
            pv[name] = tuple(v * k for v in getattr(pz, name))
        elif stage == "foam":
            fv[name] = getattr(f, name) * k
        else:
            pv[name] = getattr(pz, name) * k
    pv["instant_share"] = min(pv["instant_share"], 1.0)
    if "load_share" in fv:
        fv["load_share"] = min(fv["load_share"], 1.0)
    pv["floor_pct"] = min(pv["floor_pct"], 99.0)
    return base.with_(foam=fv, piezo=pv)


#: key of a parameter file calibrated with each record's load: {"column": COL, "unit": "g", "records": [...]}
CALIBRATED_LOAD = "calibrated_load"


def calibrated_load_column(path) -> str | None:
    """The load column (g) a parameter file was calibrated with (``porosense calibrate`` ran each
    record under the load of that column), or None for a file calibrated unloaded.

    Raises
    ------
    InputError
        An unreadable file, or a ``calibrated_load`` entry without a column or in a unit other than g.
    """
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read simulator parameters {path}: {exc}") from None
    entry = doc.get(CALIBRATED_LOAD) if isinstance(doc, dict) else None
    if not entry:
        return None
    column = entry.get("column") if isinstance(entry, dict) else None
    if not isinstance(column, str) or not column.strip() or str(entry.get("unit", "g")).strip() != "g":
        raise InputError(f"{path}: '{CALIBRATED_LOAD}' must name a load column in g, got {entry!r}")
    return column.strip()


@dataclass
class ActuatorCalibration:
    """Calibrated plant parameters and the fits before and after (%, per record and column).

    ``loaded`` names the records that ran under their recorded load (g) in the fit and in these
    figures (the others ran unloaded); ``load_column`` is the recordings' load column, None when
    the calibration ran every record unloaded."""

    actuator: str
    physics: Physics
    fit_before: dict
    fit_after: dict
    cost_evaluations: int = 0
    loaded: list = field(default_factory=list)
    load_column: str | None = None

    def to_dict(self) -> dict:
        out = {"actuator": self.actuator, "fit_before": self.fit_before, "fit_after": self.fit_after}
        if self.load_column is not None:
            out["loaded_records"] = list(self.loaded)
        return out

    def save(self, path) -> Path:
        """The parameter file (``porosense simulate --params``); calibrated with loads, it states
        the load column (``calibrated_load``) that ``simulate --params --replay`` reads."""
        extra = {"fit": self.to_dict()}
        if self.load_column is not None and self.loaded:
            extra[CALIBRATED_LOAD] = {"column": self.load_column, "unit": "g", "records": list(self.loaded)}
        return self.physics.save(path, **extra)

    def __str__(self) -> str:
        lines = [f"{self.actuator} calibrated ({self.cost_evaluations} evaluations of the residual):"]
        if self.loaded:
            lines.append(
                f"  under their recorded load (column '{self.load_column}', g): {len(self.loaded)} of "
                f"{len(self.fit_after)} records"
            )
        for name, cols in self.fit_after.items():
            lines.append(
                f"  {name}: "
                + ", ".join(f"{c} fit {self.fit_before[name][c]:.1f} -> {v:.1f} %" for c, v in cols.items())
            )
        return "\n".join(lines)


def _fits(actuator, physics, records, use_load: bool = False) -> dict:
    out = {}
    for r in records:
        sim = simulate_record(actuator, physics, r, load_g=r.load_g if use_load else None)
        cols = {f"dR_{c}": fit_percent(r.dr[:, c], sim[f"dR_{c}"]) for c in range(r.dr.shape[1])}
        cols.update({k: fit_percent(v, sim[k]) for k, v in r.outputs.items()})
        out[r.name] = cols
    return out


@single_threaded
def calibrate_actuator(
    actuator: str,
    records,
    *,
    physics: Physics | None = None,
    max_nfev: int = 80,
    use_load: bool = True,
    load_column: str | None = None,
):
    """Fit the plant's foam and contact-law parameters to recordings of one print.

    Parameters
    ----------
    actuator : str
        'contractor', 'bending' or '3dof'.
    records : list of ActuatorRecord
        Commanded vacuum (kPa), measured dR (%) and measured outputs (the actuator's units);
        a record with ``load_g`` (g) was made under that hanging load.
    physics : Physics, optional
        Starting parameters (default: the simulator's defaults).
    max_nfev : int
        Simulations of the records the least-squares fit may spend.
    use_load : bool
        Simulate each record that carries a load under it (the plant's load stress and contact
        opening, porosense.sim.plant.Plant.run), so the fitted physics is the unloaded print's;
        records without one run unloaded. False: every record unloaded (a load then ends up in
        the fitted physics).
    load_column : str, optional
        The recordings' load column (reported and saved with the parameters; default ``load_g``).

    Returns
    -------
    ActuatorCalibration
        The parameters (print-to-print variation and drift off: one print measured), the fit
        (%) of every column before and after (each record under the load it was fitted with)
        and the records that ran loaded.
    """
    records = list(records)
    if not records:
        raise InputError("no recording to calibrate from")
    loaded = [r.name for r in records if use_load and r.load_g is not None]
    base = (physics or Physics()).without("repeat_variation", "baseline_drift")
    # each column weighted by its own spread, each record by its length; samples piled up at a
    # column's extreme (a clipped ADC or divider) say only that the value is beyond the limit:
    # they leave the cost, so the physics is fitted to what the sensor saw and the clip stays a
    # cause for diagnosis to name (porosense.sim.extend: saturation)
    scales = []
    for r in records:
        s = {f"dR_{c}": max(float(np.std(r.dr[:, c])), 1e-6) for c in range(r.dr.shape[1])}
        s.update({k: max(float(np.std(v)), 1e-6) for k, v in r.outputs.items()})
        keep = {f"dR_{c}": ~piled_at_extreme(r.dr[:, c]) for c in range(r.dr.shape[1])}
        keep.update({k: ~piled_at_extreme(v) for k, v in r.outputs.items()})
        scales.append((s, 1.0 / math.sqrt(r.dr.shape[0]), keep))

    # the load's own parameters only where the loads differ (between records or within one)
    loads = [r.load_g if (use_load and r.load_g is not None) else np.zeros(1) for r in records]
    spec = _ACT + _LOAD_ACT if float(np.ptp(np.concatenate(loads))) > 0.0 else _ACT

    def residual(theta):
        ph = _actuator_physics(base, theta, spec)
        out = []
        for r, (s, w, keep) in zip(records, scales):
            sim = simulate_record(actuator, ph, r, load_g=r.load_g if use_load else None)
            for c in range(r.dr.shape[1]):
                col = f"dR_{c}"
                out.append(w * keep[col] * (sim[col] - r.dr[:, c]) / s[col])
            for k, v in r.outputs.items():
                out.append(w * keep[k] * (sim[k] - v) / s[k])
        return np.nan_to_num(np.concatenate(out), nan=1e3)

    lo = np.log([b[2] for b in spec])
    hi = np.log([b[3] for b in spec])
    sol = least_squares(residual, np.zeros(len(spec)), bounds=(lo, hi), max_nfev=max_nfev, diff_step=1e-3)
    ph = _actuator_physics(base, sol.x, spec)
    return ActuatorCalibration(
        actuator,
        ph,
        _fits(actuator, base, records, use_load),
        _fits(actuator, ph, records, use_load),
        sol.nfev,
        loaded,
        (load_column or "load_g") if use_load else None,
    )
