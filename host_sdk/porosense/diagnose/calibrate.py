"""Calibrate the actuator simulator to measured data, so that diagnosis can say what it misses.

Commanded vacuum goes in (columns ``p_cmd_0..2``, kPa), a measured column comes out (``dR_*``,
``strain_*``, ``curvature``, ``theta_x``, ``theta_y`` or ``dz``). Calibrated parameters:

* ``porosity`` (%, 60..90): the physical parameter that sets stroke and sensitivity
  (bounded scalar search, scipy.optimize.minimize_scalar);
* ``scale`` and ``offset`` of the output (sensor sensitivity and zero, in the output's unit):
  linear least squares inside every evaluation.

The simulation is the **mean recording** of the print: the simulator's recording-to-recording
draws (porosense.sim.variation: sensitivity, contact-law scale, kinetics, softening state, R0
drift) are held at their mean (factors 1, the middle of the softening range, no drift), without
noise and without any named effect (a parameter file's own effects aside, :func:`as_calibrated`).
It is the nominal physics, and what it misses is what diagnosis is asked to find.

**Each record's own state.** Real repeats differ, and the simulator says by how much
(:class:`porosense.sim.params.Variation`). For a resistance output (``dR_*``, %), every record
(estimation and validation alike) gets its own recording state, fitted on that record within the
simulator's stated prior (:data:`STATES`):

* ``gain``: the network's full drop ``floor_pct`` x exp(record_gain_sd z);
* ``scale``: the contact-law scale ``contact_strain`` x exp(record_scale_sd z);
* ``kinetics``: the contact time constants ``form_s``, ``break_s`` x exp(record_kinetics_sd z);
* ``conditioning``: the softening state at the start, in ``conditioning_range``;
* ``offset`` (% dR): the error of the record's R0 reference (the median of its first
  R0_CALIBRATION_S seconds; the R0 change between recordings cancels in dR), standard deviation
  the slow sensor noise there: sqrt(flicker_pct^2 + drift_walk_pct^2 R0_CALIBRATION_S / 60 s);
* ``drift`` (% of R0 per minute): an R0 drift rate, standard deviation drift_pct_per_min_sd; it
  enters the measured dR as rate t / 60 (1 + dR / 100).

**The rule.** Each state is fitted by least squares, bounded to its prior's central 99 % interval
(|z| <= 2.576 standard deviations for the Gaussian ones, the whole range for the uniform
softening state; scipy.optimize.lsq_linear on the simulated output linearised in the states,
finite differences of one standard deviation, relinearised once at the fit). A clean
recording's state lies inside each interval with probability 0.99, so a clean record is
followed: that is the prediction diagnosis is handed.

**The state beside a cause.** A cause the state can partly mimic (a memory or a slow relaxation
looks like slower contact kinetics, a drift like the drift state) is half absorbed by that fit.
So the diagnosis refits each record's state with every correction and extension it fits
(:class:`StateColumns`, read by porosense.diagnose.engine.Record.state): the state's Gaussian
prior (z units for gain, scale and kinetics, offset_sd, drift_sd; the softening state, flat on
its range, stays at its fit) against the record's residual counted at its effective sample
size, w |residual|^2 with w = n_eff / (N sigma^2), sigma^2 and n_eff = N / (1 + 2 sum of the
autocorrelations over their initial positive sequence) (:func:`n_effective`) of the residual
of the fit above. Each fit is then the maximum of the posterior of (extension, state): a state
far out in its prior costs what it should, so a cause is fitted, and its held-out gain measured
(each validation record's state refitted on its residual after the extension), with the state
free to move back toward its mean; the corrected baselines (nominal + G0, + the adequate-order
correction) are refitted the same way, the nominal itself is the fit above. An extension whose
gain is measured against the nominal itself (the simulator's slow_relaxation effect,
porosense.diagnose.extensions) has each validation record's state fitted after it by the rule
above instead (:meth:`StateColumns.fit`), the nominal's own: refitted by the posterior, the
nominal's validation records alone move by -0.74 to +0.92 fit points on the slow_relaxation
trials of tests/diagnose/test_diagnose_sim.py (seeds 1000-1011), by that rule by 0.00. A clean record's residual is mostly noise (n_eff 24-90 on the clean contractor trials
of tests/diagnose/test_diagnose_sim.py) and the posterior stays near the fit; a cause leaves a
coloured residual (n_eff 2.8, 30 and 16 on the three records of the hysteresis trial at seed
1000). The drift diagnosis asks of these columns whether a record's drift rate, fitted without
its bound, lies beyond the prior's 99 % interval (porosense.diagnose.extensions.drift).

The porosity, scale and offset are calibrated with the estimation records' states fitted
jointly by the rule (the print and the sensor are common to all records, the state is each
record's own): a 7-point porosity grid brackets the fit with offset and drift states only, a
bounded search refines it with every state (sensitivities taken at the bracket's best
porosity), and the states are relinearised at the result. The prior of a simulator without
recording variation (``Physics().without('repeat_variation', 'baseline_drift')``) has
zero width: every record is then the mean recording (offset aside).

Samples piled up exactly at a record's extreme (at least 10, a clipped ADC or divider) are
left out of the calibration and state fits: they only say that the output is beyond the limit.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np
from scipy import optimize
from scipy.signal import lfilter
from scipy.stats import norm

from porosense.dsp.blas import single_threaded
from porosense.dsp.heap import reuses_freed_memory
from porosense.errors import InputError

POROSITY_BOUNDS = (60.0, 90.0)
#: central prior interval a record's state is bounded to
PRIOR_LEVEL = 0.99
Z_PRIOR = float(norm.ppf(0.5 + PRIOR_LEVEL / 2.0))  # 2.576
#: the recording states fitted on each record, in the order of RecordState
STATES = ("gain", "scale", "kinetics", "conditioning", "offset", "drift")
RELINEARISE = 1  # Gauss-Newton steps after the first linearisation


def mean_recording(physics=None):
    """``physics`` (porosense.sim.Physics or None: the defaults) with the recording's draws at
    their mean: sensitivity, contact-law scale, kinetics and R0 factors 1, the softening state
    in the middle of its range, no R0 drift nor walk. The print (specimen) draws stay."""
    from porosense.sim import Physics

    ph = physics or Physics()
    v = ph.variation
    mid = 0.5 * (v.conditioning_range[0] + v.conditioning_range[1])
    return ph.with_(
        variation={
            "record_gain_sd": 0.0,
            "record_r0_sd": 0.0,
            "record_scale_sd": 0.0,
            "record_kinetics_sd": 0.0,
            "conditioning_range": (mid, mid),
            "drift_pct_per_min_sd": 0.0,
            "drift_walk_pct": 0.0,
        }
    )


@dataclass
class RecordState:
    """One record's recording state, fitted within the simulator's prior.

    Attributes: ``gain``, ``scale``, ``kinetics`` (factors on the mean recording's network drop,
    contact-law scale and contact time constants), ``conditioning`` (softening state, 0..1),
    ``offset`` (output unit), ``drift`` (% of R0 per minute), ``at_bound`` (states at their
    prior interval's edge: the record asks for more than the simulator's repeats differ by),
    ``fit`` (%, the record's fit with this state, clipped samples left out)."""

    gain: float = 1.0
    scale: float = 1.0
    kinetics: float = 1.0
    conditioning: float = float("nan")
    offset: float = 0.0
    drift: float = 0.0
    at_bound: tuple = ()
    fit: float = float("nan")
    #: the state's columns and prior for a refit beside an extension (:class:`StateColumns`), not saved
    columns: object = field(default=None, repr=False, compare=False)
    #: the record's calibrated simulation, for the simulator's own effects (:class:`Simulation`), not saved
    simulation: object = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("columns")
        d.pop("simulation")
        d["at_bound"] = list(self.at_bound)
        return d

    def __str__(self) -> str:
        s = (
            f"gain x{self.gain:.3f}, scale x{self.scale:.3f}, kinetics x{self.kinetics:.3f}, "
            f"softening {self.conditioning:.2f}, offset {self.offset:+.3f}, drift {self.drift:+.2f} %/min"
        )
        return s + (f" (at the prior bound: {', '.join(self.at_bound)})" if self.at_bound else "")


@dataclass
class StateColumns:
    """One record's recording state as nuisance regressors, for a refit beside an extension.

    ``S`` (N, k): the output's change (output unit) per unit increment of each free Gaussian
    state (z units for gain, scale and kinetics; output unit for the offset; % of R0 per minute
    for the drift), linearised at the fitted state; ``R`` (k, k) and ``t`` (k,): the prior in
    output units, so that the posterior of an increment d is maximised by the least squares of
    [residual; t] on [S; R] (R = P / sqrt(w), P the inverse prior standard deviations, t the
    prior's pull back to the mean from the fitted state, w the data weight of
    :func:`_fit_state`). d = 0 is the fitted state. ``names`` (k,): each column's state (of
    :data:`STATES`); ``sd`` (k,): its prior standard deviation in the column's unit (1 for the
    z-unit states, the offset's in the output unit, the drift's in % of R0 per minute)."""

    S: np.ndarray
    R: np.ndarray
    t: np.ndarray
    names: tuple = ()
    sd: np.ndarray | None = None
    #: % of R0 per minute: the standard deviation of the drift rate that R0's random walk alone
    #: shows over the record (least-squares slope of a random walk of q %^2 per minute over T
    #: minutes: sqrt(6 q / (5 T)))
    walk_rate_sd: float = 0.0
    #: (N,) the samples the state was fitted on (clipped samples left out, :func:`_at_limit`); None: all
    keep: np.ndarray | None = None

    def refit(self, r: np.ndarray) -> np.ndarray:
        """The state's increment d (k,) that maximises the posterior for the residual r (N,)."""
        return np.linalg.lstsq(np.vstack([self.S, self.R]), np.concatenate([r, self.t]), rcond=None)[0]

    def fit(self, r: np.ndarray) -> np.ndarray:
        """The state's increment d (k,) that the record's own fit gives for the residual r (N,)
        in the output unit: least squares bounded to the prior's central :data:`PRIOR_LEVEL` interval of
        each state (|z| <= :data:`Z_PRIOR` standard deviations about the prior's mean), the rule
        :meth:`Calibration.predict_record` fitted the state by. An increment of 0 is always allowed
        (a state already beyond its interval is not moved further out, nor forced back). Samples
        the state was not fitted on (``keep``: clipped ones) are left out, as they were."""
        if self.sd is None:
            return self.refit(r)
        v = np.array([self.value(n) for n in self.names])
        lo = np.minimum(-Z_PRIOR * self.sd - v, 0.0)
        hi = np.maximum(Z_PRIOR * self.sd - v, 0.0)
        k = np.ones(len(r), bool) if self.keep is None else self.keep
        return _lsq(self.S[k], np.asarray(r, float)[k], lo, hi)

    def moved(self, d: np.ndarray) -> StateColumns:
        """The same state after an increment d was applied to the prediction."""
        return replace(self, t=self.t - self.R @ d)

    def value(self, name: str) -> float:
        """The state ``name``'s present value (its column's unit; z units for gain, scale and
        kinetics): the prior's mean 0 less its pull back, -t_j / R_jj."""
        j = self.names.index(name)
        return float(-self.t[j] / self.R[j, j])

    def weight(self) -> float:
        """The data weight w (1 / output unit^2) the prior rows are scaled by: (P_jj / R_jj)^2."""
        return float((1.0 / (self.sd[0] * self.R[0, 0])) ** 2)


@dataclass
class Simulation:
    """One record's calibrated simulation, for the simulator's own named effects
    (porosense.sim.effects) as diagnosis' extensions (porosense.diagnose.extensions).

    ``g`` (N,) %: the static drop of the output channel's contact network
    (porosense.sim.material.ContactNetwork), simulated at the record's fitted recording state;
    ``scale``: the calibrated output scale (output unit per % dR); ``ts``: sample period, s."""

    g: np.ndarray
    scale: float
    ts: float
    #: the simulated output (output unit, N,) for a load series (N,) g, or None
    loaded: object = field(default=None, repr=False, compare=False)
    _last: tuple = field(default=(None, None), repr=False, compare=False)

    def load_dependence(self, load_g: np.ndarray) -> np.ndarray:
        """The output's change (output unit, N,) when the load during the record is ``load_g``
        (N,) g instead of the simulator's constant one: the ``load_dependence`` effect, the
        record's calibrated simulation (its fitted state) run again with that load, less itself.
        Zeros when the simulation cannot be run again."""
        load_g = np.asarray(load_g, float)
        if self.loaded is None:
            return np.zeros(len(self.g))
        if self._last[0] is None or not np.array_equal(self._last[0], load_g):
            self._last = (load_g.copy(), self.loaded(load_g))
        return self._last[1]

    def slow_relaxation(self, tau_s: float) -> np.ndarray:
        """The output's change (output unit) per unit ``gain`` of the ``slow_relaxation`` effect of
        time constant ``tau_s`` (s), as porosense.sim.plant adds it to dR:
        (g - g through a first-order lag of tau_s) (1 + g / 100), the lag started settled at g's
        first sample (the record starts at rest), times the output scale."""
        g = self.g
        a = float(np.exp(-self.ts / tau_s))
        lag = lfilter([1.0 - a], [1.0, -a], g, zi=[a * g[0]])[0]
        return self.scale * (g - lag) * (1.0 + g / 100.0)


@dataclass(frozen=True)
class _Prior:
    """Standard deviations (z units per factor: log sd) and the softening range of the states."""

    gain_sd: float
    scale_sd: float
    kinetics_sd: float
    conditioning: tuple
    offset_sd: float
    drift_sd: float
    #: R0's random walk, % of R0 rms after one minute
    walk_pct: float = 0.0

    @classmethod
    def of(cls, physics) -> _Prior:
        from porosense.sim.experiment import R0_CALIBRATION_S

        v, pz = physics.variation, physics.piezo
        return cls(
            v.record_gain_sd,
            v.record_scale_sd,
            v.record_kinetics_sd,
            tuple(float(c) for c in v.conditioning_range),
            float(np.hypot(pz.flicker_pct, v.drift_walk_pct * np.sqrt(R0_CALIBRATION_S / 60.0))),
            v.drift_pct_per_min_sd,
            v.drift_walk_pct,
        )


def _with_state(physics, z: np.ndarray, prior: _Prior):
    """The simulator at state z = (z_gain, z_scale, z_kinetics, conditioning)."""
    pz = physics.piezo
    kin = float(np.exp(prior.kinetics_sd * z[2]))
    return physics.with_(
        piezo={
            "floor_pct": min(pz.floor_pct * float(np.exp(prior.gain_sd * z[0])), 99.0),
            "contact_strain": pz.contact_strain * float(np.exp(prior.scale_sd * z[1])),
            "form_s": pz.form_s * kin,
            "break_s": pz.break_s * kin,
        },
        variation={"conditioning_range": (float(z[3]), float(z[3]))},
    )


class _Model:
    """The simulated output of one record and its sensitivities to the recording state."""

    def __init__(self, actuator, output, porosity, u, ts, physics, prior: _Prior | None, S=None, effects=None):
        self.args = (actuator, output, porosity, u, ts)
        self.physics, self.prior, self.effects = physics, prior, effects
        n = len(u)
        self.t_min = np.arange(n) * ts / 60.0  # min since the record's start (its R0 reference)
        self.set(np.array([0.0, 0.0, 0.0, float(np.mean(prior.conditioning))]) if prior else None, S)

    def set(self, z, S=None):
        """Simulate at state z and the finite-difference sensitivities (one sd, half the range);
        ``S`` (N, 4): sensitivities taken from elsewhere (zero columns: that state held)."""
        self.z = z
        if z is None:
            self.m, self.g = _simulate(*self.args, self.physics, self.effects, with_g=True)
            self.S = np.zeros((len(self.m), 0))
            return
        p = self.prior
        self.m, self.g = _simulate(*self.args, _with_state(self.physics, z, p), self.effects, with_g=True)
        if S is not None:
            self.S = S
            return
        cols = []
        for j, sd in enumerate((p.gain_sd, p.scale_sd, p.kinetics_sd)):
            if sd <= 0:
                cols.append(np.zeros_like(self.m))
                continue
            zj = z.copy()
            zj[j] += 1.0 if z[j] <= 0 else -1.0
            cols.append(
                (_simulate(*self.args, _with_state(self.physics, zj, p), self.effects) - self.m) / (zj[j] - z[j])
            )
        lo, hi = p.conditioning
        if hi > lo:
            zj = z.copy()
            h = 0.5 * (hi - lo)
            zj[3] = z[3] + h if z[3] + h <= hi else z[3] - h
            cols.append(
                (_simulate(*self.args, _with_state(self.physics, zj, p), self.effects) - self.m) / (zj[3] - z[3])
            )
        else:
            cols.append(np.zeros_like(self.m))
        self.S = np.column_stack(cols)

    def columns(self, scale: float, offset: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Regressors of the state (dz, offset, drift) for output = scale m + offset, and bounds."""
        if self.z is None:
            return np.zeros((len(self.m), 0)), np.zeros(0), np.zeros(0)
        p, z = self.prior, self.z
        level = 1.0 + (scale * self.m + offset) / 100.0
        A = np.column_stack([scale * self.S, np.ones_like(self.m), self.t_min * level])
        lo = np.array([-Z_PRIOR - z[0], -Z_PRIOR - z[1], -Z_PRIOR - z[2], p.conditioning[0] - z[3], 0, 0])
        hi = np.array([Z_PRIOR - z[0], Z_PRIOR - z[1], Z_PRIOR - z[2], p.conditioning[1] - z[3], 0, 0])
        lo[4], hi[4] = -Z_PRIOR * p.offset_sd, Z_PRIOR * p.offset_sd
        lo[5], hi[5] = -Z_PRIOR * p.drift_sd, Z_PRIOR * p.drift_sd
        sd = np.array(
            [p.gain_sd, p.scale_sd, p.kinetics_sd, p.conditioning[1] - p.conditioning[0], p.offset_sd, p.drift_sd]
        )
        held = sd <= 0
        held[:4] |= ~self.S.any(axis=0)
        A[:, held] = 0.0
        lo[held] = hi[held] = 0.0
        return A, lo, hi


def _lsq(A, b, lo, hi):
    """Bounded least squares; a zero-width bound fixes its coefficient at the bound."""
    fixed = hi - lo <= 0
    x = np.where(fixed, lo, 0.0)
    free = ~fixed
    if free.any():
        r = b - A[:, fixed] @ x[fixed]
        # the same least squares on the triangular factor (a few columns, thousands of samples)
        q, R = np.linalg.qr(A[:, free])
        x[free] = optimize.lsq_linear(R, q.T @ r, bounds=(lo[free], hi[free]), method="bvls").x
    return x


@dataclass
class Calibration:
    """Calibrated simulator: actuator, porosity (%), output scale and offset, fit (%) on the
    estimation samples it was calibrated on (clipped samples left out, each record with its
    fitted state)."""

    actuator: str
    output: str
    porosity: float
    scale: float
    offset: float
    fit_estimation: float
    #: the simulator's stage parameters (porosense.sim.Physics; None: the defaults), not saved
    physics: object = field(default=None, repr=False, compare=False)
    #: the states fitted to the estimation records during the calibration
    states: list = field(default_factory=list, repr=False)
    #: named effects the simulator runs with (a parameter file's, porosense.sim.effects), not saved
    effects: object = field(default=None, repr=False, compare=False)

    @property
    def porosity_at_bound(self) -> bool:
        """True when the calibrated porosity sits at an end of POROSITY_BOUNDS: the print's
        parameters could not follow the data, so the fit took up something beyond them (a hidden
        leak ends there, measured on the 3-DoF trials)."""
        return any(abs(self.porosity - b) < 1e-3 for b in POROSITY_BOUNDS)

    def _nominal(self):
        return mean_recording(self.physics)

    def _prior(self):
        from porosense.sim import Physics

        return _Prior.of(self.physics or Physics()) if self.output.startswith("dR_") else None

    def predict(self, p_cmd: np.ndarray, ts: float) -> np.ndarray:
        """Simulated output of the mean recording for commanded vacuum p_cmd (N, n_channels) kPa,
        sampled every ts s (output unit)."""
        return (
            self.scale * _simulate(self.actuator, self.output, self.porosity, p_cmd, ts, self._nominal(), self.effects)
            + self.offset
        )

    @single_threaded
    def predict_record(self, p_cmd: np.ndarray, y: np.ndarray, ts: float) -> tuple[np.ndarray, RecordState]:
        """Simulated output for one measured record with its own recording state fitted on it
        (the rule of the module docstring): p_cmd (N, n_channels) kPa, y (N,) the measured output
        (output unit), ts s. Returns the prediction (output unit) and the state."""
        from porosense.dsp.metrics import fit_percent

        y = np.asarray(y, float)
        keep = ~_at_limit(y) if len(y) >= 10 else np.ones(len(y), bool)
        if keep.sum() < 10:
            keep[:] = True
        model = _Model(
            self.actuator, self.output, self.porosity, p_cmd, ts, self._nominal(), self._prior(), effects=self.effects
        )
        pred, x = _fit_state(model, y, keep, self.scale, self.offset)
        state = _state(model, x, self.scale)
        state.columns = getattr(model, "columns_at_fit", None)
        if model.g is not None:
            at = _with_state(model.physics, model.z, model.prior) if model.z is not None else model.physics
            base = model.m.copy()

            def loaded(load, at=at, base=base, u=p_cmd):
                m = _simulate(self.actuator, self.output, self.porosity, u, ts, at, self.effects, load=load)
                return self.scale * (m - base)

            state.simulation = Simulation(model.g, float(self.scale), float(ts), loaded)
        state.fit = float(fit_percent(y[keep], pred[keep]))
        return pred, state

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("physics")
        d.pop("effects")
        d["states"] = [s.to_dict() for s in self.states]
        return d


def n_effective(r: np.ndarray) -> float:
    """Effective sample size of a coloured residual r (N,): N / (1 + 2 sum_k rho_k), the sum of
    its autocorrelations rho_k over the initial positive sequence (lags 1.. until the first
    rho_k <= 0), at least 1."""
    r = np.asarray(r, float) - np.mean(r)
    n = len(r)
    v = float(r @ r)
    if n < 3 or v <= 0:
        return float(max(n, 1))
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n] / v
    neg = np.flatnonzero(ac[1:] <= 0.0)
    k = int(neg[0]) if neg.size else n - 1
    return float(max(1.0, n / (1.0 + 2.0 * float(np.sum(ac[1 : 1 + k])))))


def _prior_rows(model: _Model, lo, hi):
    """Rows of the Gaussian prior on the state's increments (P dx = t): one per Gaussian state
    that is not held (z units for gain, scale, kinetics; offset_sd, drift_sd); the uniform
    softening state has none (its prior is flat on its range)."""
    p, z = model.prior, model.z
    sd = np.array([1.0, 1.0, 1.0, np.inf, p.offset_sd, p.drift_sd])
    at = np.array([z[0], z[1], z[2], 0.0, 0.0, 0.0])
    rows = [j for j in range(6) if np.isfinite(sd[j]) and sd[j] > 0 and hi[j] > lo[j]]
    P = np.zeros((len(rows), 6))
    for i, j in enumerate(rows):
        P[i, j] = 1.0 / sd[j]
    return P, -at[rows] / sd[rows] if rows else np.zeros(0)


def _fit_state(model: _Model, y, keep, scale, offset):
    """Fit one record's state at the given output scale and offset: (prediction, coefficients).

    Least squares inside the prior's central interval (the module docstring's rule); the data
    weight of the state's posterior, w = n_eff / (N sigma^2) from the residual of that fit
    (:func:`n_effective`), is kept with the state's columns (``model.columns_at_fit``) for the
    diagnosis' refits."""
    x = np.zeros(6)
    model.columns_at_fit = None
    for step in range(RELINEARISE + 1):
        A, lo, hi = model.columns(scale, offset)
        base = scale * model.m + offset
        if A.shape[1] == 0:
            return base, x
        x = _lsq(A[keep], (y - base)[keep], lo, hi)
        if step < RELINEARISE and np.any(x[:4] != 0):
            model.set(model.z + x[:4])
    A, lo, hi = model.columns(scale, offset)
    e = (y - scale * model.m - offset - A @ x)[keep]
    var = float(np.mean(e * e))
    if var > 0:
        model.columns_at_fit = _state_columns(model, A, lo, hi, x, n_effective(e) / (len(e) * var))
        if model.columns_at_fit is not None and not keep.all():
            model.columns_at_fit.keep = np.asarray(keep, bool).copy()
    return scale * model.m + offset + A @ x, x


def _state_columns(model: _Model, A, lo, hi, x, w) -> StateColumns | None:
    """The fitted state's Gaussian states as :class:`StateColumns` (the softening state, flat on
    its range, and held states left out)."""
    P, t = _prior_rows(model, lo, hi)
    if not len(t) or not np.isfinite(w) or w <= 0:
        return None
    cols = np.flatnonzero(P.any(axis=0))
    Pk = P[:, cols]
    names = tuple(STATES[j] for j in cols)
    t_min = max(float(model.t_min[-1]), 1e-9)
    walk = float(np.sqrt(1.2 * model.prior.walk_pct**2 / t_min))
    return StateColumns(A[:, cols], Pk / np.sqrt(w), (t - P @ x) / np.sqrt(w), names, 1.0 / np.diag(Pk), walk)


def _state(model: _Model, x, scale) -> RecordState:
    if model.z is None:
        return RecordState()
    p = model.prior
    z = model.z + x[:4]
    at = []
    for name, zi, lim in zip(("gain", "scale", "kinetics"), z[:3], (p.gain_sd, p.scale_sd, p.kinetics_sd)):
        if lim > 0 and abs(zi) >= Z_PRIOR * (1 - 1e-6):
            at.append(name)
    lo, hi = p.conditioning
    if hi > lo and (z[3] <= lo + 1e-9 or z[3] >= hi - 1e-9):
        at.append("conditioning")
    for name, xi, sd in (("offset", x[4], p.offset_sd), ("drift", x[5], p.drift_sd)):
        if sd > 0 and abs(xi) >= Z_PRIOR * sd * (1 - 1e-6):
            at.append(name)
    return RecordState(
        float(np.exp(p.gain_sd * z[0])),
        float(np.exp(p.scale_sd * z[1])),
        float(np.exp(p.kinetics_sd * z[2])),
        float(z[3]),
        float(x[4]),
        float(x[5]),
        tuple(at),
    )


def _simulate(
    actuator: str,
    output: str,
    porosity,
    p_cmd: np.ndarray,
    ts: float,
    physics=None,
    effects=None,
    with_g=False,
    load=None,
):
    """The simulated ``output`` (N,), and with ``with_g`` also the output channel's static drop g
    (N,) % (None for an output that is no channel's dR); ``load`` (N,) g: the load during the
    record (None: the simulator's constant load)."""
    from porosense import sim

    g_key = f"g_{output[3:]}" if output.startswith("dR_") else None

    p = np.asarray(p_cmd, float).reshape(len(p_cmd), -1)
    if effects:  # a parameter file's named effects: dR as the electronics read it (porosense.sim.calibrate)
        from porosense.sim.calibrate import ActuatorRecord, simulate_record

        out = simulate_record(
            actuator,
            physics or sim.Physics(),
            ActuatorRecord(p, ts, np.zeros_like(p)),
            porosity=porosity,
            effects=effects,
            load_g=load,
        )
        if output not in out:
            raise InputError(f"the {actuator} simulator has no output '{output}'")
        y = np.asarray(out[output], float)
        return (y, out.get(g_key)) if with_g else y
    sp = np.zeros((len(p), 3))
    sp[:, : p.shape[1]] = np.minimum(p, 0.0)
    on = sp < 0.0
    plant = sim.make_plant(actuator, porosity=porosity, noise=False, physics=physics)
    out = plant.run(ts, sp, on, on.copy(), load_g=load)
    if output not in out:
        raise InputError(
            f"the {actuator} simulator has no output '{output}' "
            f"(it has {', '.join(k for k in out if not k.startswith(('voltage', 'euler', 't_', 'g_')))})"
        )
    y = np.asarray(out[output], float)  # sample k as a recording stores it
    return (y, out.get(g_key)) if with_g else y


def _at_limit(y: np.ndarray, min_count: int = 10) -> np.ndarray:
    """Samples exactly at the record's minimum or maximum when at least ``min_count`` sit there."""
    tol = 1e-6 * (float(np.ptp(y)) or 1.0)
    out = np.zeros(len(y), bool)
    for ext in (y.min(), y.max()):
        at = np.abs(y - ext) <= tol
        if at.sum() >= min_count:
            out |= at
    return out


def _joint(models: list, ys: list, keeps: list):
    """Output scale and offset with every record's state, fitted jointly (bounded least squares
    on the linearised states): (scale, offset, [state coefficients per record], cost)."""
    ms = np.concatenate([m.m for m in models])
    yy = np.concatenate(ys)
    kk = np.concatenate(keeps)
    X = np.column_stack([ms, np.ones_like(ms)])
    (a0, b0), *_ = np.linalg.lstsq(X[kk], yy[kk], rcond=None)
    blocks = [m.columns(a0, b0) for m in models]
    width = sum(A.shape[1] for A, _, _ in blocks)
    if width == 0:
        r = (yy - X @ (a0, b0))[kk]
        return float(a0), float(b0), [np.zeros(6) for _ in models], float(r @ r)
    A = np.zeros((len(yy), 2 + width))
    A[:, :2] = X
    lo, hi = [-np.inf, -np.inf], [np.inf, np.inf]
    row = col = 0
    for Ai, li, hi_i in blocks:
        n, w = Ai.shape
        A[row : row + n, 2 + col : 2 + col + w] = Ai
        lo.extend(li)
        hi.extend(hi_i)
        row += n
        col += w
    x = _lsq(A[kk], yy[kk], np.array(lo), np.array(hi))
    r = (yy - A @ x)[kk]
    xs = [x[2 + 6 * i : 8 + 6 * i] for i in range(len(models))]
    return float(x[0]), float(x[1]), xs, float(r @ r)


@single_threaded
@reuses_freed_memory
def calibrate(
    actuator: str, output: str, u_list: list, y_list: list, ts: float, physics=None, effects=None
) -> Calibration:
    """Fit porosity, scale and offset of ``actuator``'s ``output`` to the estimation records, each
    record with its own recording state (the rule of the module docstring).

    ``u_list``: commanded vacuum per record, (N, n_channels) kPa; ``y_list``: the measured output
    (N,) per record, output unit; ``ts``: sample period, s. ``physics`` (porosense.sim.Physics or
    None for the defaults) is the simulator calibrated: its mean recording is the nominal and
    its Variation the prior of each record's state; ``effects`` (porosense.sim.effects, None:
    none) are named effects the simulator runs with."""
    from porosense.dsp.metrics import fit_percent
    from porosense.sim import Physics

    ph = physics or Physics()
    nominal = mean_recording(ph)
    prior = _Prior.of(ph) if output.startswith("dR_") else None
    ys = [np.asarray(y, float) for y in y_list]
    # samples piled up exactly at a record's extreme are clipped (ADC or divider limit): they
    # say only that the output is beyond the limit, so they do not pull the calibration
    keeps = [~_at_limit(y) for y in ys]
    if sum(k.sum() for k in keeps) < 10:
        keeps = [np.ones(len(y), bool) for y in ys]

    def models(por, sens=None):
        sens = sens or [None] * len(u_list)
        return [_Model(actuator, output, por, u, ts, nominal, prior, S, effects=effects) for u, S in zip(u_list, sens)]

    # the porosity grid brackets the fit with the mean recording (offset and drift states only),
    # the bounded search refines it with every state, its sensitivities taken at the bracket's
    # best porosity (they change slowly with porosity), and the states are relinearised at the end
    held = [np.zeros((len(u), 4)) for u in u_list] if prior is not None else None
    grid = np.linspace(*POROSITY_BOUNDS, 7)
    costs = [_joint(models(p, held), ys, keeps)[3] for p in grid]
    k = int(np.argmin(costs))
    sens = [m.S for m in models(grid[k])] if prior is not None else None

    def cost(por):
        return _joint(models(por, sens), ys, keeps)[3]

    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    sol = optimize.minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 0.05})
    por = float(sol.x) if sol.fun <= cost(grid[k]) else float(grid[k])
    ms = models(por)
    scale, offset, xs, _ = _joint(ms, ys, keeps)
    if prior is not None:  # relinearise every record's state at the fit, then the scale and offset once more
        for m, x in zip(ms, xs):
            if np.any(x[:4] != 0):
                m.set(m.z + x[:4])
        scale, offset, xs, _ = _joint(ms, ys, keeps)
    preds, states = [], []
    for m, x in zip(ms, xs):
        A, _, _ = m.columns(scale, offset)
        preds.append(scale * m.m + offset + (A @ x if A.shape[1] else 0.0))
        states.append(_state(m, x, scale))
    kk = np.concatenate(keeps)
    fit = fit_percent(np.concatenate(ys)[kk], np.concatenate(preds)[kk])
    for s, y, p, kp in zip(states, ys, preds, keeps):
        s.fit = float(fit_percent(y[kp], p[kp]))
    return Calibration(actuator, output, por, scale, offset, float(fit), physics, states, effects)


def as_calibrated(actuator: str, output: str, physics, effects=None) -> Calibration:
    """A calibrated parameter file (porosense calibrate, or one extended by diagnose
    --save-extended) as a :class:`Calibration`: its physics' mean recording at its own porosity,
    output scale 1 and offset 0, ``effects`` its named effects; each record's state is fitted
    by :meth:`Calibration.predict_record` as for a calibration."""
    return Calibration(actuator, output, None, 1.0, 0.0, float("nan"), physics, [], effects or None)
