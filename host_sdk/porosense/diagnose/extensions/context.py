"""What every cause's handler works on and returns: the residual :class:`Context` (estimation
and validation records, the model's own dynamics, the baseline corrections and the fits of an
extension), the :class:`CauseResult` of a handler, the constants they share (baseline corrections,
state refits, Laguerre order, pole grid) and the small helpers every handler uses.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from porosense.diagnose import dynamics, signals, stats
from porosense.dsp import laguerre_bank

LAGUERRE_ORDER = 4


FIT_RCOND = 1e-6


#: baseline corrections (:meth:`Context.base`)
GENERIC = "generic"


ADEQUATE = "adequate"


CONSTANT = "constant"


#: how a validation record's recording state is refitted after an extension (Record.state): the
#: posterior's maximum under the state's prior, or the record's own fit (least squares within the
#: prior's 99 % interval, the rule the nominal's validation states were fitted by)
POSTERIOR = "posterior"


OWN = "own"


#: causes whose extension is a linear dynamic change: judged against the nominal model with the
#: generic correction only (the adequate-order correction would absorb them)
DYNAMICS = ("unmodelled_dynamics", "time_delay", "slow_relaxation")


#: relative RMS (of the prediction's SD) below which a linear filter reproduces a prediction: a
#: linear model's prediction is met at its own order to 1e-8..1e-7 (a model simulated in its own
#: form, refitted by least squares); one pole fewer leaves percents
EXACT_RMS = 1e-6


#: slow cosines of time per record that render a drift (its test; hysteresis is tested beyond them)
DRIFT_TERMS = 3


POLE_GRID = (0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.975, 0.99, 0.995)


@dataclass
class CauseResult:
    test: stats.StatResult
    gate: bool
    meaning: str
    extension: str
    yhat_val: np.ndarray | None
    detail: dict = field(default_factory=dict)
    #: the extension's regressors on the estimation records (beyond G0): what the ranking scores
    Z_est: np.ndarray | None = None
    #: how many candidate regressor sets the handler searched (a delay, a time constant, a side)
    n_search: int = 1
    #: log-likelihood ratio of evidence outside the residual regression (a pile-up at a limit)
    evidence_llr: float = 0.0


def _huber_lstsq(X: np.ndarray, y: np.ndarray, iters: int = 10) -> np.ndarray:
    """Huber-loss linear regression by iteratively reweighted least squares (k = 1.345 sigma)."""
    coef = stats.lstsq(X, y)
    for _ in range(iters):
        r = y - X @ coef
        s = 1.4826 * np.median(np.abs(r - np.median(r))) or 1e-12
        w = np.minimum(1.0, 1.345 * s / np.maximum(np.abs(r), 1e-300))
        sw = np.sqrt(w)
        coef = stats.lstsq(X * sw[:, None], y * sw)
    return coef


class Context:
    """Estimation and validation records with the shared regressors of all handlers."""

    def __init__(self, estimation, validation, correct: bool = True, state_fit: str = POSTERIOR):
        self.state_fit = state_fit
        self.est = list(estimation)
        self.val = list(validation)
        self.ts = float(self.est[0].ts)
        self.n_in = self.est[0].u.shape[1]
        self.seg_est = [len(r.y) for r in self.est]
        self.e_est = np.concatenate([r.e for r in self.est])
        self.yhat_est = np.concatenate([r.yhat for r in self.est])
        self.yhat_val = np.concatenate([r.yhat for r in self.val])
        self.y_val = np.concatenate([r.y for r in self.val])
        self.u_est = np.vstack([r.u for r in self.est])
        self.pole = self._dominant_pole()
        self.base_ba = self._base_dynamics()
        self.G0_est = self.stack(self.generic, self.est)
        self.G0_val = self.stack(self.generic, self.val)
        # the linear dynamics the data support (see :mod:`..dynamics`): unmodelled_dynamics' extension
        self.adequate = dynamics.choose([r.u for r in self.est], [r.e for r in self.est]) if correct else None
        if correct:
            self.A_est = self.stack(lambda r: self.adequate.regressors(r.u), self.est)
            self.A_val = self.stack(lambda r: self.adequate.regressors(r.u), self.val)
        else:
            self.A_est, self.A_val = np.zeros((len(self.e_est), 0)), np.zeros((len(self.y_val), 0))
        self._cache = {}

    # -- regressors -------------------------------------------------------------------------
    @staticmethod
    def stack(fn, records) -> np.ndarray:
        return np.vstack([np.asarray(fn(r), float).reshape(len(r.y), -1) for r in records])

    def lag_bank(self, x: np.ndarray, order: int = LAGUERRE_ORDER, pole: float | None = None) -> np.ndarray:
        """Laguerre bank of x started in steady state at its rest level (:func:`..signals.rest_level`)."""
        a = self.pole if pole is None else pole
        x0 = signals.rest_level(x)
        return laguerre_bank(np.asarray(x, float) - x0, a, order) + x0 * np.sqrt(1.0 - a * a) / (1.0 - a)

    def generic(self, rec) -> np.ndarray:
        """G0: Laguerre bank of every used input and a constant (retunes the linear dynamics)."""
        cols = [self.lag_bank(rec.u[:, i]) for i in range(self.n_in)]
        return np.column_stack(cols + [np.ones(len(rec.y))])

    def _dominant_pole(self) -> float:
        """Laguerre pole that best reproduces the prediction from the inputs (its time scale)."""
        best = (np.inf, 0.8)
        yh = self.yhat_est
        if np.ptp(yh) == 0:
            return 0.8
        for a in POLE_GRID:
            X = self.stack(
                lambda r: np.column_stack(
                    [self.lag_bank(r.u[:, i], LAGUERRE_ORDER, a) for i in range(self.n_in)] + [np.ones(len(r.y))]
                ),
                self.est,
            )
            c = stats.lstsq(X, yh)
            rss = float(np.sum((yh - X @ c) ** 2))
            if rss < best[0] * 0.999:
                best = (rss, a)
        return best[1]

    def _base_dynamics(self, max_order: int = 6):
        """ARX (b, a) from the first input to the prediction: the model's own linear dynamics.

        For a linear model of a noise-free prediction this recovers its transfer function; for
        a nonlinear one its best linear approximation. Order by BIC; None if none is stable.
        """
        best = None
        self.model_order = None
        for n in range(1, max_order + 1):
            rows, target = [], []
            for r in self.est:
                y, x = r.yhat, r.u[:, 0]
                N = len(y)
                cols = [-y[n - j : N - j] for j in range(1, n + 1)] + [x[n - j : N - j] for j in range(0, n + 1)]
                rows.append(np.column_stack(cols + [np.ones(N - n)]))
                target.append(y[n:])
            X, t = np.vstack(rows), np.concatenate(target)
            c = stats.lstsq(X, t)
            rss = float(np.sum((t - X @ c) ** 2)) + 1e-300
            a = np.concatenate([[1.0], c[:n]])
            if np.any(np.abs(np.roots(a)) >= 0.9999):
                continue
            # a linear model's prediction is reproduced to rounding error at its own order: that
            # order is the model's (BIC, below, would keep adding poles that fit rounding noise)
            if self.model_order is None and rss <= EXACT_RMS**2 * len(t) * (float(np.var(t)) or 1.0):
                self.model_order = n
            bic = len(t) * np.log(rss / len(t)) + (2 * n + 2) * np.log(len(t))
            if best is None or bic < best[0]:
                best = (bic, c[n : 2 * n + 1], a)
        if self.model_order is None and best is not None:
            self.model_order = len(best[2]) - 1
        return None if best is None else (best[1], best[2])

    def base_filter(self, x: np.ndarray) -> np.ndarray:
        """x through the model's own linear dynamics (unit DC gain), from steady state at its rest level."""
        from scipy import signal as sps

        if self.base_ba is None:
            return self.lag_bank(x, 1)[:, 0]
        b, a = self.base_ba
        dc = np.sum(b) / np.sum(a)
        b = b / dc if abs(dc) > 1e-12 else b
        zi = sps.lfilter_zi(b, a) * signals.rest_level(x)
        return sps.lfilter(b, a, x, zi=zi)[0]

    @property
    def tau_s(self) -> float:
        """Time constant (s) of the dominant pole."""
        return -self.ts / np.log(self.pole)

    @property
    def slowest_tau_s(self) -> float:
        """Time constant (s) of the slowest pole of the model's own linear dynamics (:meth:`_base_dynamics`;
        the dominant Laguerre pole's when they are unknown)."""
        if self.base_ba is not None:
            r = np.abs(np.roots(self.base_ba[1])) if len(self.base_ba[1]) > 1 else np.zeros(0)
            r = r[(r > 0) & (r < 1)]
            if r.size:
                return float(-self.ts / np.log(r.max()))
        return self.tau_s

    # -- fitting ----------------------------------------------------------------------------
    def corrected(self, scope: str = ADEQUATE) -> tuple[list, list]:
        """(estimation, validation) records whose prediction is the nominal + the correction of
        ``scope`` (fitted on estimation): the model the other causes are judged against."""
        val, est, d_val, d_est = self._fit(None, scope=scope)

        def parts(records, pred, ds):
            cuts = np.cumsum([len(r.y) for r in records])[:-1]
            return [
                type(r)(
                    r.u,
                    r.y,
                    p,
                    r.ts,
                    r.conditions,
                    r.column_kinds,
                    r.state.moved(d) if r.state is not None else None,
                    r.simulation,
                )
                for r, p, d in zip(records, np.split(pred, cuts), ds)
            ]

        return parts(self.est, est, d_est), parts(self.val, val, d_val)

    def base(self, scope: str = ADEQUATE) -> tuple[np.ndarray, np.ndarray]:
        """(estimation, validation) regressors of a baseline correction, the constant last.

        ``constant``: an offset only; ``generic``: G0 (Laguerre bank at the model's own pole, and a
        constant); ``adequate``: G0 and the adequate-order linear correction (:mod:`..dynamics`).
        """
        if scope == GENERIC:
            return self.G0_est, self.G0_val
        if scope == CONSTANT:
            return np.ones((len(self.e_est), 1)), np.ones((len(self.y_val), 1))
        return (
            np.column_stack([self.A_est, self.G0_est]),
            np.column_stack([self.A_val, self.G0_val]),
        )

    def f_test(self, Z_est: np.ndarray, extra_base: np.ndarray | None = None, scope: str = ADEQUATE) -> stats.FTest:
        """GLS F test of Z beyond the baseline correction of ``scope`` (and ``extra_base``)."""
        b = self.base(scope)[0][:, :-1]
        base = b if extra_base is None else np.column_stack([b, extra_base])
        return stats.gls_f_test(self.e_est, Z_est, base, segments=self.seg_est)

    def fit_apply(
        self,
        z_fn=None,
        *,
        robust: bool = False,
        mask_est: np.ndarray | None = None,
        scope: str = ADEQUATE,
        fixed=None,
        state_fit: str | None = None,
    ):
        """Fit e ~ [baseline of ``scope``, Z] on estimation; return (extended yhat on validation, on estimation).

        ``fixed``: a function of a record giving a term (N,) of the output's unit added to its
        prediction with coefficient 1 before the fit (a simulator's effect with its parameters set).

        Records that carry their recording state (``Record.state``: a calibrated simulation's,
        porosense.diagnose.calibrate.StateColumns) have it refitted with the extension: on the
        estimation records jointly with the extension's coefficients, on each validation record
        on its own residual after the extension (the same rule as its fit: the posterior's
        maximum under the state's prior). A cause the state partly mimics is so fitted with the
        state free to move back toward its mean, and its held-out gain measured so. ``state_fit``
        (None: the context's): :data:`POSTERIOR`, or :data:`OWN`, each validation record's state
        fitted by the nominal's own rule (calibrate.StateColumns.fit), for an extension whose gain
        is measured against the nominal itself."""
        return self._fit(z_fn, robust=robust, mask_est=mask_est, scope=scope, fixed=fixed, state_fit=state_fit)[:2]

    def _fit(
        self,
        z_fn=None,
        *,
        robust: bool = False,
        mask_est: np.ndarray | None = None,
        scope: str = ADEQUATE,
        fixed=None,
        state_fit: str | None = None,
    ):
        """:meth:`fit_apply` and the states' increments: (val, est, [d per validation record], [d per
        estimation record]; d None for a record without a state)."""
        Xe, Xv = self.base(scope)
        if z_fn is not None:
            Xe = np.column_stack([Xe, self.stack(z_fn, self.est)])
            Xv = np.column_stack([Xv, self.stack(z_fn, self.val)])
        e, yhat_est, yhat_val = self.e_est, self.yhat_est, self.yhat_val
        if fixed is not None:
            f_est, f_val = self.stack(fixed, self.est)[:, 0], self.stack(fixed, self.val)[:, 0]
            e, yhat_est, yhat_val = e - f_est, yhat_est + f_est, yhat_val + f_val
        rows = np.ones(len(e), bool) if mask_est is None else ~mask_est
        n_x = Xe.shape[1]
        Se, R, t, spans = self._state_blocks()
        A = np.column_stack([Xe, Se])[rows]
        b = e[rows]
        if len(t):
            A = np.vstack([A, np.column_stack([np.zeros((len(t), n_x)), R])])
            b = np.concatenate([b, t])
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        if robust:
            coef = _huber_lstsq(A / scale, b)
        else:
            # SVD with directions below 1e-6 of the largest singular value left out: nearly
            # collinear regressors (a model output and a filter bank of its input) would otherwise
            # take large opposite coefficients that cancel on estimation and not on validation
            coef = np.linalg.lstsq(A / scale, b, rcond=FIT_RCOND)[0]
        coef = coef / scale
        est = yhat_est + Xe @ coef[:n_x] + Se @ coef[n_x:]
        d_est = [None if sp is None else coef[n_x + sp[0] : n_x + sp[1]] for sp in spans]
        val = yhat_val + Xv @ coef[:n_x]
        d_val, start = [], 0
        for r in self.val:
            n = len(r.y)
            d = None
            if r.state is not None:
                resid = r.y - val[start : start + n]
                d = r.state.fit(resid) if (state_fit or self.state_fit) == OWN else r.state.refit(resid)
                val[start : start + n] += r.state.S @ d
            d_val.append(d)
            start += n
        return val, est, d_val, d_est

    def _state_blocks(self):
        """The estimation records' states: block columns (N_est, K), prior rows (K, K), targets (K,),
        and each record's column span (None without a state)."""
        if "state_blocks" not in self._cache:
            cols = sum(r.state.S.shape[1] for r in self.est if r.state is not None)
            Se = np.zeros((len(self.e_est), cols))
            R = np.zeros((cols, cols))
            t = np.zeros(cols)
            spans, row, col = [], 0, 0
            for r in self.est:
                n = len(r.y)
                if r.state is None:
                    spans.append(None)
                else:
                    k = r.state.S.shape[1]
                    Se[row : row + n, col : col + k] = r.state.S
                    R[col : col + k, col : col + k] = r.state.R
                    t[col : col + k] = r.state.t
                    spans.append((col, col + k))
                    col += k
                row += n
            self._cache["state_blocks"] = (Se, R, t, spans)
        return self._cache["state_blocks"]

    def baseline_validation(self, scope: str = ADEQUATE) -> np.ndarray:
        """Nominal + the baseline correction of ``scope``, fitted on estimation, on validation."""
        if scope not in self._cache:
            self._cache[scope] = self.fit_apply(None, scope=scope)
        return self._cache[scope][0]

    # -- report data ------------------------------------------------------------------------
    def residual_tests(self, alpha: float) -> dict:
        out = {"autocorrelation": stats.residual_autocorrelation(self.e_est, 25, alpha)}
        for i in range(self.n_in):
            out[f"crosscorrelation_u{i}"] = stats.input_crosscorrelation(self.u_est[:, i], self.e_est, 25, alpha)
        bv = stats.billings_voon(self.u_est[:, 0], self.e_est, 20, alpha)
        out.update({f"billings_voon_{k}": v for k, v in bv.items()})
        return out

    def curves(self, results: dict) -> dict:
        return {
            "ts": self.ts,
            "e_est": self.e_est,
            "yhat_est": self.yhat_est,
            "y_val": self.y_val,
            "yhat_val": self.yhat_val,
            "extended_val": {c: r.yhat_val for c, r in results.items() if r.yhat_val is not None},
            "spectrum": results["periodic_disturbance"].test.detail,
            "spectrum_significant": bool(results["periodic_disturbance"].test.significant),
        }


# ------------------------------------------------------------------------------------------------
def _explained(test) -> str:
    return f"{100 * test.detail.get('explained', 0.0):.1f} % of the whitened residual"


def _simulated(ctx: Context) -> bool:
    """Whether every record comes from a calibrated simulator that computes its own effects
    (porosense.diagnose.engine.Record.simulation)."""
    return all(r.simulation is not None for r in ctx.est + ctx.val)
