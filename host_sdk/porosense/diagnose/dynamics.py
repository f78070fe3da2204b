"""The linear dynamics the data support: an adequate-order linear correction of the residual.

Diagnosis judges the baseline's linear part before any nonlinear cause: a too-low order would
otherwise leak into whichever nonlinear extension happens to absorb the missing dynamics. The
correction is a MISO output-error model of the estimation residual,

    e[k] = sum_i B_i(q) / F_i(q) u_i[k] + c,   m poles and m + 1 taps (lags 0..m) per input,

fitted by :func:`fit_output_error` (simulation error from a settled start, least squares with
the analytic Jacobian). With
the denominators F_i fixed the correction is linear in its numerators: its regressors, every
input through q^-j / F_i(q), join the generic correction in every extension fit, so that each
nonlinear cause is judged beyond an adequate-order linear model.

The order is the Bayesian information criterion's choice over m = 1..MAX_ORDER (Gaussian
likelihood of the simulation error, k = n_in (2m + 1) + 1 parameters; the search stops after
two orders without improvement). Process noise and nonlinear distortion make the residual
coloured, which biases BIC towards higher orders: the correction errs towards too many poles,
never towards too few, which is the safe side for judging nonlinear causes beyond it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal
from scipy.stats import t as sps_t

from porosense.diagnose import signals, stats
from porosense.dsp.metrics import fit_percent

MAX_ORDER = 10


def _settled(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """x through 1 / a started in steady state at its rest level (:func:`.signals.rest_level`)."""
    x = np.asarray(x, float)
    if len(a) == 1:
        return x / a[0]
    zi = signal.lfilter_zi([1.0], a) * signals.rest_level(x)
    return signal.lfilter([1.0], a, x, zi=zi)[0]


def _lagged(x: np.ndarray, lags: int) -> np.ndarray:
    """Columns x[k - j], j = 0..lags, the samples before the record at its rest level."""
    n = len(x)
    out = np.empty((n, lags + 1))
    x0 = signals.rest_level(x)
    for j in range(lags + 1):
        out[: min(j, n), j] = x0
        out[j:, j] = x[: max(n - j, 0)]
    return out


def _arx_start(us: list, es: list, m: int) -> tuple[np.ndarray, list]:
    """Per-input denominators (monic, stable) and numerators from a common-denominator ARX fit."""
    rows, rhs = [], []
    for u, e in zip(us, es):
        lag_e = _lagged(e - signals.rest_level(e), m)
        cols = [-lag_e[:, 1:]] + [_lagged(u[:, i] - signals.rest_level(u[:, i]), m) for i in range(u.shape[1])]
        rows.append(np.column_stack(cols + [np.ones(len(e))]))
        rhs.append(lag_e[:, 0])
    coef = stats.lstsq(np.vstack(rows), np.concatenate(rhs))
    a = _stable(np.concatenate([[1.0], coef[:m]]))
    n_in = us[0].shape[1]
    return a, [coef[m + i * (m + 1) : m + (i + 1) * (m + 1)] for i in range(n_in)]


def _stable(a: np.ndarray) -> np.ndarray:
    """Monic polynomial a with roots on or outside the unit circle reflected inside (|z| <= 0.995)."""
    if len(a) <= 1:
        return a
    r = np.roots(a)
    big = np.abs(r) >= 0.995
    if not big.any():
        return a
    r = np.where(big, 0.995 * r / np.abs(r) ** 2, r)
    return np.real(np.poly(r))


def _unpack(theta: np.ndarray, n_in: int, m: int):
    bs, fs = [], []
    for i in range(n_in):
        k = i * (2 * m + 1)
        bs.append(theta[k : k + m + 1])
        fs.append(np.concatenate([[1.0], theta[k + m + 1 : k + 2 * m + 1]]))
    return bs, fs, theta[-1]


def _simulate(theta, us, m, with_jacobian: bool):
    """OE output per record (settled at each input's rest level) and, optionally, its Jacobian."""
    n_in = us[0].shape[1]
    bs, fs, c = _unpack(theta, n_in, m)
    outs, jacs = [], []
    for u in us:
        y = np.full(len(u), c)
        cols = []
        for i in range(n_in):
            x0 = signals.rest_level(u[:, i])
            dx = u[:, i] - x0
            b, f = bs[i], fs[i]
            sf, sb = float(np.sum(f)), float(np.sum(b))
            yi = signal.lfilter(b, f, dx)
            y += yi + sb / sf * x0
            if with_jacobian:
                xf = signal.lfilter([1.0], f, dx)
                yf = signal.lfilter([1.0], f, yi)
                cols.append(_lagged_zero(xf, m) + x0 / sf)
                cols.append(-_lagged_zero(yf, m)[:, 1:] - sb / sf**2 * x0)
        outs.append(y)
        if with_jacobian:
            jacs.append(np.column_stack(cols + [np.ones(len(u))]))
    return outs, jacs


def _lagged_zero(x: np.ndarray, lags: int) -> np.ndarray:
    """Columns x[k - j], j = 0..lags, zero before the record (a signal that starts from zero)."""
    n = len(x)
    out = np.zeros((n, lags + 1))
    for j in range(lags + 1):
        out[j:, j] = x[: max(n - j, 0)]
    return out


def fit_output_error(us: list, es: list, m: int) -> tuple[np.ndarray, list, list]:
    """MISO output-error fit of es from us: (theta, numerators, denominators), m poles per input.

    Started from an ARX fit, refined by scipy.optimize.least_squares with the analytic
    Jacobian (the regressors filtered by 1 / F_i); each record starts settled at its rest level.
    """
    n_in = us[0].shape[1]
    a, b0 = _arx_start(us, es, m)
    theta0 = np.concatenate([np.concatenate([b, a[1:]]) for b in b0] + [[0.0]])
    outs, _ = _simulate(theta0, us, m, False)
    theta0[-1] = float(np.mean(np.concatenate(es) - np.concatenate(outs)))
    e_all = np.concatenate(es)

    def res(theta):
        return np.concatenate(_simulate(theta, us, m, False)[0]) - e_all

    def jac(theta):
        return np.vstack(_simulate(theta, us, m, True)[1])

    with np.errstate(over="ignore", invalid="ignore"):  # trial steps far out are rejected by trf itself
        sol = optimize.least_squares(res, theta0, jac=jac, method="trf", x_scale="jac", max_nfev=30)
    bs, fs, _ = _unpack(sol.x, n_in, m)
    fs = [_stable(f) for f in fs]
    return sol.x, bs, fs


@dataclass
class Correction:
    """An adequate-order linear correction: ``order`` poles per input and their denominators.

    ``bic`` maps every order tried to its criterion value (lower is better).
    """

    order: int
    denominators: list
    bic: dict

    def regressors(self, u: np.ndarray) -> np.ndarray:
        """The correction's regressors on one record (inputs (N, n_in)), without the constant."""
        u = np.asarray(u, float).reshape(len(u), -1)
        return np.column_stack([_lagged(_settled(f, u[:, i]), self.order) for i, f in enumerate(self.denominators)])

    @property
    def n_params(self) -> int:
        """Poles and numerator taps of the correction (the constant is part of every baseline)."""
        return len(self.denominators) * (2 * self.order + 1)

    def describe(self) -> str:
        return f"{self.order} poles per input (the order the Bayesian information criterion picks, 1..{MAX_ORDER})"


def choose(us: list, es: list, max_order: int = MAX_ORDER) -> Correction:
    """The adequate-order correction of the residuals ``es`` (list of (N,)) from inputs ``us``.

    us: list of (N_r, n_in) input arrays; es: list of (N_r,) residuals of the same records.
    """
    us = [np.asarray(u, float).reshape(len(u), -1) for u in us]
    es = [np.asarray(e, float) for e in es]
    n = sum(len(e) for e in es)
    n_in = us[0].shape[1]
    max_order = int(min(max_order, max(1, min(len(e) for e in es) // 50)))
    bic, fits = {}, {}
    worse = 0
    for m in range(1, max_order + 1):
        theta, _bs, fs = fit_output_error(us, es, m)
        sse = float(sum(np.sum((y - e) ** 2) for y, e in zip(_simulate(theta, us, m, False)[0], es))) + 1e-300
        bic[m] = n * np.log(sse / n) + (n_in * (2 * m + 1) + 1) * np.log(n)
        fits[m] = fs
        worse = worse + 1 if bic[m] > min(bic.values()) else 0
        if worse >= 2:
            break
    best = min(bic, key=bic.get)
    return Correction(best, [np.asarray(f, float) for f in fits[best]], {m: float(v) for m, v in bic.items()})


@dataclass
class DelayOrPole:
    """A dead time against one more pole: the two simplest linear explanations of a late response.

    Both are output-error models of the measured output from the inputs with the nominal model's
    number of poles ``order``: ``delay`` keeps that order and delays the inputs by ``delay``
    samples (one parameter more than the nominal: the delay); ``pole`` adds one pole and one tap
    and keeps the one-sample delay of a sampled system (two parameters more). Both are fitted on
    the estimation records; ``test`` compares their squared errors on the validation records,
    scored after the slower model has settled from the unknown state before each record (batch
    means, :func:`.stats.paired_gain_test`, the delay model as the extension, one-sided 5 %).
    ``prefers_delay``: the dead time predicts better (confirmed); ``prefers_pole``: one more pole
    predicts better (the delay's gain refuted); neither: the data cannot tell them apart, or
    neither linear model renders the data's dynamics: the model diagnosed (``fit_nominal``, its
    prediction on the same samples) predicts the validation records better than both
    (``nominal_better``, one-sided 5 % each, batch means), so what tells them apart is how each
    misfits what the linear models leave out (a nonlinear response), not the start of the response.
    """

    delay: int
    order: int
    fit_delay: float
    fit_pole: float
    test: stats.GainTest
    fit_nominal: float = float("nan")
    nominal_better: bool = False

    @property
    def prefers_delay(self) -> bool:
        """The dead time predicts the validation records better than one more pole (one-sided 5 %)."""
        return bool(self.test.confirmed and not self.nominal_better)

    @property
    def prefers_pole(self) -> bool:
        """One more pole predicts the validation records better than the dead time (one-sided 5 %)."""
        return bool(self.test.refuted and not self.nominal_better)

    def sentence(self) -> str:
        return (
            f"on validation a linear model of the measured output with {self.order} pole"
            f"{'s' if self.order > 1 else ''} and a dead time of {self.delay} samples fits {self.fit_delay:.2f} %, "
            f"one with {self.order + 1} poles and no dead time {self.fit_pole:.2f} % "
            f"(paired t = {self.test.t:.3g}, one-sided p = {self.test.p:.2g})"
            + (
                f"; the model diagnosed predicts better than both ({self.fit_nominal:.2f} %, one-sided 5 % each), so "
                "they do not render the data's dynamics and say nothing of a dead time"
                if self.nominal_better
                else ""
            )
        )


def _shifted(us: list, d: int) -> list:
    return [np.column_stack([signals.shift(u[:, i], d) for i in range(u.shape[1])]) for u in us]


def _oe_fit_predict(us_est: list, ys_est: list, us_val: list, order: int, d: int) -> tuple[float, list, float]:
    """(estimation SSE, validation predictions per record, slowest time constant in samples) of an
    OE model of ``order`` poles on inputs delayed by d."""
    se, sv = _shifted(us_est, d), _shifted(us_val, d)
    theta, _, fs = fit_output_error(se, ys_est, order)
    sse = float(sum(np.sum((y - p) ** 2) for y, p in zip(ys_est, _simulate(theta, se, order, False)[0])))
    radius = max([float(np.max(np.abs(np.roots(f)))) for f in fs if len(f) > 1] or [0.0])
    tau = -1.0 / np.log(radius) if 0.0 < radius < 1.0 else 0.0
    return sse, _simulate(theta, sv, order, False)[0], tau


#: time constants after which a record's unknown initial state has decayed below 1 % (e^-4.6)
SETTLE_TAUS = 4.6


def delay_or_pole(
    us_est: list, ys_est: list, us_val: list, ys_val: list, order: int, delays, yhat_val: list | None = None
) -> DelayOrPole:
    """Compare a dead time (the best of ``delays`` >= 2 samples on estimation) with one more pole.

    us_*: lists of (N_r, n_in) inputs; ys_*: lists of (N_r,) measured outputs (output units);
    order: the nominal model's poles; yhat_val: the model diagnosed's prediction of each
    validation record (output units; optional). See :class:`DelayOrPole`.
    """
    us_est = [np.asarray(u, float).reshape(len(u), -1) for u in us_est]
    us_val = [np.asarray(u, float).reshape(len(u), -1) for u in us_val]
    ys_est = [np.asarray(y, float) for y in ys_est]
    y_val = np.concatenate([np.asarray(y, float) for y in ys_val])
    order = max(1, int(order))
    fits = [(_oe_fit_predict(us_est, ys_est, us_val, order, d), d) for d in sorted({max(2, int(d)) for d in delays})]
    (_, pred_delay, tau_delay), d = min(fits, key=lambda f: f[0][0])
    _, pred_pole, tau_pole = _oe_fit_predict(us_est, ys_est, us_val, order + 1, 1)
    # both are scored where the state before each record no longer matters: after SETTLE_TAUS
    # time constants of the slower model (at most half the record)
    keep = []
    for y in ys_val:
        skip = int(min(np.ceil(SETTLE_TAUS * max(tau_delay, tau_pole)) + d, len(y) // 2))
        keep.append(np.arange(len(y)) >= skip)
    keep = np.concatenate(keep)
    pred_delay, pred_pole = np.concatenate(pred_delay)[keep], np.concatenate(pred_pole)[keep]
    y_val = y_val[keep]
    fit_nom, nominal_better = float("nan"), False
    if yhat_val is not None:
        nom = np.concatenate([np.asarray(p, float) for p in yhat_val])[keep]
        fit_nom = float(fit_percent(y_val, nom))
        nominal_better = all(stats.paired_gain_test(y_val, p, nom).confirmed for p in (pred_delay, pred_pole))
    return DelayOrPole(
        int(d),
        order,
        float(fit_percent(y_val, pred_delay)),
        float(fit_percent(y_val, pred_pole)),
        stats.paired_gain_test(y_val, pred_pole, pred_delay),
        fit_nom,
        bool(nominal_better),
    )


#: a relaxation's time constant is at least this multiple of the model's slowest one: the
#: shortest time constant the slow-mode test tries (:func:`.extensions._slow_sets`, twice the
#: model's own), so that the test and this evidence mean the same thing by "slow"
SLOW_RATIO = 2.0


@dataclass
class SlowPole:
    """Where the pole a linear model needs beyond the nominal's lies: slow (a relaxation) or not.

    A linear output-error model of the measured output with one pole more than the nominal
    (``order`` poles) is fitted on the estimation records, started both from an ARX fit and from
    the nominal order's fit with one extra pole at ``tau_start_s`` (the lower estimation error
    wins). Its slowest time constant ``tau_s`` is compared with SLOW_RATIO times the nominal
    model's slowest, ``tau_nominal_s``: t = (ln tau_s - ln(SLOW_RATIO tau_nominal_s)) / se,
    se the standard error of ln tau_s by the delta method from a batch sandwich covariance of
    the fit (N_BATCHES contiguous batches of the estimation samples, for a coloured error),
    on N_BATCHES - 1 df. ``slow``: tau_s is beyond SLOW_RATIO tau_nominal_s at one-sided
    ``alpha``; ``not_slow``: it is below at one-sided ``alpha``; neither: the data cannot tell.
    """

    tau_s: float
    tau_nominal_s: float
    order: int
    t: float
    df: int
    alpha: float = stats.CONFIRM_ALPHA

    @property
    def p_slow(self) -> float:
        """One-sided p of tau_s > SLOW_RATIO tau_nominal_s."""
        return float(sps_t.sf(self.t, self.df)) if self.df > 0 else 1.0

    @property
    def slow(self) -> bool:
        """The extra pole is slower than SLOW_RATIO times the nominal's slowest (one-sided alpha)."""
        return bool(self.p_slow < self.alpha)

    @property
    def not_slow(self) -> bool:
        """The extra pole is faster than SLOW_RATIO times the nominal's slowest (one-sided alpha)."""
        return bool(self.df > 0 and sps_t.cdf(self.t, self.df) < self.alpha)

    def sentence(self) -> str:
        verdict = "slow" if self.slow else ("not slow" if self.not_slow else "undecided")
        return (
            f"a linear model of the measured output with {self.order} poles has its slowest time constant "
            f"at {self.tau_s:.3g} s against the nominal model's {self.tau_nominal_s:.3g} s ({verdict}: "
            f"beyond {SLOW_RATIO:g}x at t = {self.t:.3g} on {self.df} df, one-sided p = {self.p_slow:.2g})"
        )


def _numerators(us: list, ys: list, fs: list, m: int) -> np.ndarray:
    """theta of an OE model with the denominators ``fs`` fixed: numerators and constant by least squares."""
    corr = Correction(m, fs, {})
    X = np.vstack([np.column_stack([corr.regressors(u), np.ones(len(u))]) for u in us])
    coef = stats.lstsq(X, np.concatenate(ys))
    n_in = us[0].shape[1]
    # the regressors are each input's deviation through q^-j / F_i started at its rest level:
    # the same parametrisation as :func:`_simulate` (b on the deviation, DC of the rest level)
    parts = [np.concatenate([coef[i * (m + 1) : (i + 1) * (m + 1)], fs[i][1:]]) for i in range(n_in)]
    return np.concatenate(parts + [[coef[-1]]])


def _refine(theta0: np.ndarray, us: list, ys: list, m: int) -> np.ndarray:
    y_all = np.concatenate(ys)

    def res(theta):
        return np.concatenate(_simulate(theta, us, m, False)[0]) - y_all

    def jac(theta):
        return np.vstack(_simulate(theta, us, m, True)[1])

    with np.errstate(over="ignore", invalid="ignore"):
        return optimize.least_squares(res, theta0, jac=jac, method="trf", x_scale="jac", max_nfev=30).x


def _slowest(theta: np.ndarray, n_in: int, m: int):
    """(input, root) of the slowest pole of the OE model theta."""
    _, fs, _ = _unpack(theta, n_in, m)
    best = (0, 0.0 + 0.0j)
    for i, f in enumerate(fs):
        for z in np.roots(f):
            if abs(z) > abs(best[1]):
                best = (i, complex(z))
    return best


def slow_pole(us: list, ys: list, order: int, tau_nominal_s: float, tau_start_s: float, ts: float) -> SlowPole:
    """Is the pole that a linear model of the measured output needs beyond the nominal's slow?

    Parameters
    ----------
    us : list of ndarray, shape (N_r, n_in)
        Inputs of the estimation records, in the model's input units.
    ys : list of ndarray, shape (N_r,)
        Measured outputs of the same records.
    order : int
        The nominal model's number of poles (the fitted model has one more).
    tau_nominal_s : float
        The nominal model's slowest time constant, s.
    tau_start_s : float
        A time constant to start the extra pole at (the slow-mode fit's), s.
    ts : float
        Sample period, s.

    Returns
    -------
    SlowPole
        The fitted slowest time constant (s) and its one-sided tests against SLOW_RATIO times
        the nominal's (see :class:`SlowPole`).
    """
    us = [np.asarray(u, float).reshape(len(u), -1) for u in us]
    ys = [np.asarray(y, float) for y in ys]
    n_in = us[0].shape[1]
    order = max(1, int(order))
    m = order + 1
    starts = [fit_output_error(us, ys, m)[0]]
    _, _, fs_n = fit_output_error(us, ys, order)
    a_slow = float(np.exp(-ts / max(tau_start_s, ts)))
    starts.append(_refine(_numerators(us, ys, [np.convolve(f, [1.0, -a_slow]) for f in fs_n], m), us, ys, m))
    y_all = np.concatenate(ys)

    def sse(theta):
        return float(np.sum((np.concatenate(_simulate(theta, us, m, False)[0]) - y_all) ** 2))

    theta = min(starts, key=sse)
    i, z = _slowest(theta, n_in, m)
    r = abs(z)
    if not 0.0 < r < 1.0:
        return SlowPole(float("inf") if r >= 1.0 else 0.0, tau_nominal_s, m, 0.0, 0)
    tau = -ts / np.log(r)
    # delta method: d ln tau / d a_j of the root z of F(z) = z^m + a_1 z^(m-1) + ... + a_m
    _, fs, _ = _unpack(theta, n_in, m)
    dF = np.polyval(np.polyder(fs[i]), z)
    grad = np.zeros(len(theta))
    for j in range(1, m + 1):
        dz = -(z ** (m - j)) / dF
        dr = float(np.real(np.conj(z) * dz)) / r
        grad[i * (2 * m + 1) + m + j] = -dr / (r * np.log(r))
    # batch sandwich covariance of theta (contiguous batches of the error, which is coloured)
    J = np.vstack(_simulate(theta, us, m, True)[1])
    e = y_all - np.concatenate(_simulate(theta, us, m, False)[0])
    b = int(min(stats.N_BATCHES, len(e) // 10))
    if b < 3:
        return SlowPole(float(tau), tau_nominal_s, m, 0.0, 0)
    H = np.linalg.pinv(J.T @ J)
    g = np.array([Jb.T @ eb for Jb, eb in zip(np.array_split(J, b), np.array_split(e, b))])
    g = g - g.mean(axis=0)
    cov = H @ (g.T @ g) * b / (b - 1) @ H
    var = float(grad @ cov @ grad)
    if not np.isfinite(var) or var <= 0.0:  # a fit too ill-conditioned to say: undecided
        return SlowPole(float(tau), tau_nominal_s, m, 0.0, 0)
    t = (np.log(tau) - np.log(SLOW_RATIO * tau_nominal_s)) / np.sqrt(var)
    return SlowPole(float(tau), float(tau_nominal_s), m, float(t), b - 1)
