"""Diagnosis: residual tests -> named causes -> extensions refitted -> gain on validation.

The thing diagnosed (a calibrated simulation, an identified model, any predictor) enters only
through its predictions ``yhat`` on the estimation and validation records, so the same engine
serves ``--sim``, ``--model`` and ``--baseline``.

Procedure (no cause-specific rule anywhere):

1. G0, the generic linear correction (a Laguerre bank of every used input at the model's own
   dominant pole, and a constant), is fitted to the estimation residual.
2. Each cause's test (see :mod:`.extensions`) is conditional on G0 and run at alpha / K
   (K causes in the catalogue, Bonferroni: alpha family-wise, 1 % by default).
   unmodelled_dynamics tests G0 itself against the nominal residual (independence from past
   inputs). A cause is *found* when its test is significant AND its extension is not refuted
   on held-out data: the paired difference of validation squared errors (baseline minus
   extension) is tested by batch means (:func:`.stats.paired_gain_test`, 20 contiguous
   batches, t on 19 df); an extension worse than its baseline at one-sided 5 % is refuted, so
   an effect that is real on estimation but too small against the residual's own noise to carry
   to a new record (or a delay that re-identification would make worse) is not reported. The
   false-alarm level stays the test's alpha / K. Model extensions are judged in simulation mode
   against nominal + G0 (against the nominal for unmodelled_dynamics, whose extension is G0
   itself). Drift and periodic disturbance trackers are judged by their test alone: their walk
   or phase cannot carry to a new record in simulation, and the only predictor-mode baseline
   here (nominal + G0 with an AR one-step predictor of its residual) already follows a slow
   trend, so the tracker's paired test is reported in the evidence but not used.
3. Found causes are ranked by the Bayesian information criterion of their extension's
   regressors on the estimation residual (Gaussian likelihood of the AR-whitened residual,
   parameters = regressors + AR order, plus 2 ln M for a search over M candidates). The
   confidence of a found cause is its BIC weight exp(-BIC/2) among the found causes times
   (1 - p). Two causes within 2 ln 10 of BIC (a Bayes factor below 10) are reported as a tie,
   with the F tests that tell them apart.
4. The gain of every extension is a simulation-mode fit difference on the validation records
   against nominal + G0, on the same samples (samples an extension rejects are dropped from
   both sides). Extensions that need the measured output (drift, periodic disturbance
   trackers) are reported separately as one-step predictors against the one-step predictor of
   nominal + G0 with an AR model of its residual.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from porosense.diagnose import extensions, signals, stats
from porosense.diagnose.catalogue import CAUSES, EXPRESSIBLE, NONE
from porosense.dsp.metrics import fit_percent, rms_percent
from porosense.errors import InputError
from porosense.files import write_text


@dataclass
class Record:
    """One record: inputs u (N, n_in), output y (N,), prediction yhat (N,), extra columns."""

    u: np.ndarray
    y: np.ndarray
    yhat: np.ndarray
    ts: float
    conditions: dict = field(default_factory=dict)

    def __post_init__(self):
        self.u = np.asarray(self.u, float).reshape(len(self.u), -1)
        self.y = np.asarray(self.y, float)
        self.yhat = np.asarray(self.yhat, float)
        self.conditions = {k: np.asarray(v, float) for k, v in self.conditions.items()}
        n = len(self.y)
        if len(self.u) != n or len(self.yhat) != n or any(len(v) != n for v in self.conditions.values()):
            raise InputError("inputs, output, prediction and condition columns must have the same length")
        if n < 50:
            raise InputError(f"a record of {n} samples is too short to diagnose (need at least 50)")

    @property
    def e(self) -> np.ndarray:
        return self.y - self.yhat

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.y)) * self.ts


@dataclass
class Finding:
    """One cause with its test, evidence and the gain of its extension on validation."""

    cause: str
    confidence: float
    statistic: str
    evidence: str
    extension: str
    fit_before: float
    fit_after: float
    gain: float
    rms_before: float = float("nan")
    rms_after: float = float("nan")
    strength: float = 0.0
    significant: bool = False
    bic: float = float("nan")
    effect_to_noise: float = 0.0
    predictor_gain: float | None = None
    on_device: str = ""

    def to_dict(self) -> dict:
        """The JSON form: exactly the keys of the diagnosis report."""
        keys = (
            "cause",
            "confidence",
            "statistic",
            "evidence",
            "extension",
            "fit_before",
            "fit_after",
            "gain",
            "significant",
            "effect_to_noise",
            "predictor_gain",
            "on_device",
        )
        d = asdict(self)
        return {k: (round(d[k], 4) if isinstance(d[k], float) else d[k]) for k in keys}

    def __str__(self) -> str:
        return (
            f"{self.cause:<21} conf {self.confidence:.2f}  fit {self.fit_before:6.2f} -> "
            f"{self.fit_after:6.2f} % (gain {self.gain:+.2f})  {self.statistic}"
        )


@dataclass
class Diagnosis:
    """Ranked findings (most likely first), the residual statistics and what plots need."""

    top: str
    findings: list
    residual_tests: dict
    curves: dict = field(default_factory=dict, repr=False)
    ties: list = field(default_factory=list)
    extended: object = field(default=None, repr=False)

    def to_dict(self) -> dict:
        return {"top": self.top, "findings": [f.to_dict() for f in self.findings], "ties": self.ties}

    def to_json(self, path) -> None:
        write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")

    def finding(self, cause: str) -> Finding:
        return next(f for f in self.findings if f.cause == cause)

    def __str__(self) -> str:
        lines = [f"top: {self.top}"] + [f"  {f}" for f in self.findings]
        lines += [f"  tie: {' / '.join(t['causes'])}: {t['evidence']}" for t in self.ties]
        return "\n".join(lines)

    def plot(self, directory) -> list:
        """Write the figures into ``directory``; returns their paths (see :mod:`.report`)."""
        from porosense.diagnose import report

        return report.write_figures(self, directory)


TIE_BIC = 2.0 * np.log(10.0)  # a Bayes factor below 10 does not tell two causes apart


def _common_ar(ctx, Zs: list) -> np.ndarray:
    """One AR noise model for every candidate: fitted to the residual of e_est on G0 and the
    union of all candidates' regressors, so that no candidate's systematic error is absorbed
    into its own noise model (a slow error looks like a near-unit-root AR otherwise)."""
    X = np.column_stack([ctx.G0_est] + [Z for Z in Zs if Z is not None])
    coef = stats.lstsq(X, ctx.e_est)
    return signals.fit_ar(ctx.e_est - X @ coef, 10)


def _bic(ctx, Z: np.ndarray | None, ar: np.ndarray, with_g0: bool = True):
    """(BIC, effect SD / noise SD) of e_est ~ [G0 or constant, Z] by GLS with the AR noise model ``ar``.

    Regression on AR-filtered data (per record); BIC = N ln s2 + k ln N with s2 the whitened
    residual's variance (the noise model is common to all candidates, so its order cancels).
    The effect is the SD of the fitted Z part, the noise the residual's own SD implied by the AR
    model and s2 (the strength relative to the residual's own noise).
    """
    e = ctx.e_est
    n = len(e)
    X = ctx.G0_est if with_g0 else np.ones((n, 1))
    kz = 0 if Z is None else Z.shape[1]
    if kz:
        X = np.column_stack([X, Z])
    cuts = np.cumsum(ctx.seg_est)[:-1]
    ew = np.concatenate([signals.whiten(p, ar) for p in np.split(e, cuts)])
    Xw = np.vstack([signals.whiten(p, ar) for p in np.split(X, cuts)])
    coef = stats.lstsq(Xw, ew)
    w = ew - Xw @ coef
    s2 = float(np.mean(w * w)) or 1e-300
    bic = len(w) * np.log(s2) + X.shape[1] * np.log(len(w))
    if kz:
        effect = float(np.std(Z @ coef[-kz:]))
    elif with_g0:
        effect = float(np.std(ctx.G0_est[:, :-1] @ coef[:-1]))
    else:
        effect = 0.0
    # SD of an AR process with this innovation variance: s2 / (1 - sum of rho_k a_k) ~ via impulse response
    from scipy import signal as sps

    h = sps.lfilter([1.0], ar, np.r_[1.0, np.zeros(2000)])
    noise = np.sqrt(s2 * float(np.sum(h * h)))
    return float(bic), effect / noise


def _tie_evidence(ctx, a: str, b: str, results: dict, alpha: float) -> str:
    """F tests of each cause's regressors beyond the other's: what tells the two apart."""
    out = []
    for x, y in ((a, b), (b, a)):
        Zx, Zy = results[x].Z_est, results[y].Z_est
        if Zx is None:
            out.append(f"{x} has no regressors beyond G0")
            continue
        t = ctx.f_test(Zx, extra_base=Zy)
        r = stats.f_result(f"F({x} | {y})", t, alpha)
        out.append(f"{x} beyond {y}: F = {r.value:.3g}, p = {r.p:.2g}")
    return "; ".join(out)


def _predictor_gain(ctx, res, keep):
    """(gain, tracker, baseline): one-step predictor gain of a tracker extension against the
    one-step predictor nominal + G0 + AR(residual); (None, None, None) for other extensions."""
    trk = res.detail.get("predictor_val")
    if trk is None:
        return None, None, None
    from scipy import signal as sps

    g0_val, g0_est = ctx.fit_apply(None)
    y_est = np.concatenate([r.y for r in ctx.est])
    ar = signals.fit_ar(y_est - g0_est, 10)
    r_val = ctx.y_val - g0_val
    _parts, start, pred = [], 0, []
    for rec in ctx.val:
        n = len(rec.y)
        rv = r_val[start : start + n]
        # one-step prediction of the residual from its past: r[k] ~ -sum a_j r[k-j]
        pred.append(sps.lfilter(np.concatenate([[0.0], -ar[1:]]), [1.0], rv))
        start += n
    base = g0_val + np.concatenate(pred)
    return float(fit_percent(ctx.y_val[keep], trk[keep]) - fit_percent(ctx.y_val[keep], base[keep])), trk, base


def diagnose(
    estimation: list, validation: list, *, alpha: float = stats.DEFAULT_ALPHA, nominal=None, refit: bool = True
) -> Diagnosis:
    """Diagnose predictions against measurements.

    estimation, validation: lists of :class:`Record` (validation may repeat estimation if no
    held-out data exists, then the gain is in-sample). alpha: family-wise false-alarm level
    over the catalogue (each cause is tested at alpha / K). nominal: the identified model the
    predictions come from (a :class:`porosense.ident.Model`), when there is one: the top
    cause's extension is then a model (re-identified or wrapped, see :mod:`.extend`) that can
    be saved, predicted and, where the on-device structure carries it, quantised.
    """
    if not estimation or not validation:
        raise InputError("diagnosis needs at least one estimation and one validation record")
    ctx = extensions.Context(estimation, validation)
    per_cause_alpha = alpha / len(CAUSES)
    results = {cause: extensions.HANDLERS[cause](ctx, per_cause_alpha) for cause in CAUSES}

    g0_val = ctx.generic_validation()
    y_val = ctx.y_val
    fit_nom = fit_percent(y_val, ctx.yhat_val)
    ar = _common_ar(ctx, [r.Z_est for r in results.values() if r.gate and r.test.significant])
    bic_none, _ = _bic(ctx, None, ar, with_g0=False)
    findings, found = {}, {}
    for cause, res in results.items():
        if res.Z_est is not None:
            bic, eff = _bic(ctx, res.Z_est, ar)
        else:
            bic, eff = np.inf, 0.0
        bic += 2.0 * np.log(max(res.n_search, 1)) - 2.0 * res.evidence_llr
        keep = res.detail.get("score_mask", np.ones(len(y_val), bool))
        pred = res.yhat_val if res.yhat_val is not None else g0_val
        fit0, rms0 = fit_percent(y_val[keep], g0_val[keep]), rms_percent(y_val[keep], g0_val[keep])
        fit1, rms1 = fit_percent(y_val[keep], pred[keep]), rms_percent(y_val[keep], pred[keep])
        pgain, trk, trk_base = _predictor_gain(ctx, res, keep)
        # confirmation in the extension's own mode (see the module docstring, step 2)
        if trk is not None:
            confirm = stats.paired_gain_test(y_val[keep], trk_base[keep], trk[keep])
            refuted = False  # reported, not used: see the module docstring, step 2
        else:
            base = ctx.yhat_val if res.detail.get("gain_against") == "nominal" else g0_val
            confirm = stats.paired_gain_test(y_val[keep], base[keep], pred[keep])
            refuted = confirm.refuted
        found[cause] = bool(res.gate and res.test.significant and np.isfinite(bic) and not refuted)
        dropped = int((~keep).sum())
        sentence = (
            f"{res.test.sentence()}: {res.meaning}. Effect {eff:.3g} x the residual's noise. "
            f"Simulation on validation: nominal {fit_nom:.1f} %, nominal + G0 {fit0:.1f} %, extension "
            f"({res.extension}) {fit1:.1f} % (gain {fit1 - fit0:+.2f} points, RMS {rms0:.2f} -> {rms1:.2f} %"
            + (f", {dropped} rejected samples left out of both" if dropped else "")
            + ")."
            + (
                f" As a one-step predictor: {pgain:+.2f} points against the one-step predictor of "
                "nominal + G0 (not comparable with the simulation figures)."
                if pgain is not None
                else ""
            )
            + f" {confirm.sentence()}."
        )
        findings[cause] = Finding(
            cause,
            0.0,
            f"{res.test.name} = {res.test.value:.4g}",
            sentence,
            res.extension,
            float(fit0),
            float(fit1),
            float(fit1 - fit0),
            float(rms0),
            float(rms1),
            res.test.strength,
            found[cause],
            float(bic),
            float(eff),
            pgain,
            "expressible" if cause in EXPRESSIBLE else "not expressible",
        )
    # confidences: BIC weights among the found causes, times (1 - p)
    hits = sorted((c for c in CAUSES if found[c]), key=lambda c: (findings[c].bic, c))
    if hits:
        b0 = findings[hits[0]].bic
        w = {c: np.exp(-0.5 * (findings[c].bic - b0)) for c in hits}
        total = sum(w.values())
        for c in hits:
            findings[c].confidence = float(np.clip(w[c] / total * (1.0 - results[c].test.p), 0.0, 1.0))
    worst = max(results.values(), key=lambda r: r.test.strength).test
    p_none = min((results[c].test.p for c in hits), default=1.0)
    threshold = -np.log10(per_cause_alpha)
    findings[NONE] = Finding(
        NONE,
        float(min(p_none, min((findings[c].confidence for c in hits), default=1.0))),
        f"largest test strength -log10 p = {worst.strength:.3g}",
        f"largest test strength -log10 p = {worst.strength:.3g} ({worst.name}), threshold "
        f"{threshold:.3g} (each cause at {100 * per_cause_alpha:.3g} %, {100 * alpha:g} % family-wise).",
        "none",
        float(fit_percent(y_val, g0_val)),
        float(fit_percent(y_val, g0_val)),
        0.0,
        bic=float(bic_none),
    )
    rest = sorted((c for c in CAUSES if not found[c]), key=lambda c: (-findings[c].strength, c))
    order = [findings[c] for c in hits] + [findings[NONE]] + [findings[c] for c in rest]
    ties = []
    for c in hits[1:]:
        if findings[c].bic - findings[hits[0]].bic < TIE_BIC:
            ties.append(
                {
                    "causes": [hits[0], c],
                    "delta_bic": round(findings[c].bic - findings[hits[0]].bic, 3),
                    "evidence": _tie_evidence(ctx, hits[0], c, results, per_cause_alpha),
                }
            )
    diag = Diagnosis(order[0].cause, order, ctx.residual_tests(per_cause_alpha), ctx.curves(results), ties)
    if nominal is not None and refit and hits:
        from porosense.diagnose import extend

        extend.attach(diag, ctx, results, nominal)
    return diag
