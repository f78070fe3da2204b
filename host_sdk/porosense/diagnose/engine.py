"""Diagnosis: residual tests -> named causes -> extensions refitted -> gain on held-out data.

The thing diagnosed (a calibrated simulation, an identified model, any predictor) enters only
through its predictions ``yhat`` on the estimation and validation records, so the same engine
serves ``--sim``, ``--model`` and ``--baseline``.

Procedure:

1. **Dynamics before nonlinearity.** The residual's linear part is judged first: an
   adequate-order linear correction (:mod:`.dynamics`, order by BIC) is fitted to the
   estimation residual. unmodelled_dynamics is that correction (with G0, the generic Laguerre
   correction at the model's own pole); its gain is measured against the **nominal** model. The
   other linear-dynamics causes (time_delay, slow_relaxation) are alternatives to it, judged
   against the nominal model as well, and must show a gain from their own terms against the
   nominal model + G0. Every other cause is tested and fitted beyond the **adequate-order
   linear model + G0** (the "corrected" model), so a too-low order cannot masquerade as a
   nonlinear cause: what the missing dynamics explain is credited to unmodelled_dynamics.
2. **Tests.** Each cause's test (see :mod:`.extensions`) runs at alpha / K (K causes,
   Bonferroni: alpha family-wise, 1 % by default).
3. **Evidence that agrees with the name.** time_delay needs the measured response to start
   later than the model's (prewhitened input-output cross-correlation), a held-out gain
   from the delay itself and a measured output that does not prefer one more pole to a dead
   time on held-out data (:func:`.dynamics.delay_or_pole`; when it prefers the dead time at
   one-sided 5 %, time_delay explains the linear deficit; when the model diagnosed predicts better
   than both linear models, they say nothing of a dead time); slow_relaxation a held-out gain from
   the slow mode itself, beyond static_nonlinearity's extension too (a bend of a dynamic output
   changes its transients with the level), and a slow missing pole: the measured output
   re-identified with one pole more than the nominal puts its slowest pole beyond twice the nominal's slowest time constant
   (:func:`.dynamics.slow_pole`; below it at one-sided 5 %, the evidence disagrees with the name;
   beyond it at one-sided 5 %, slow_relaxation explains the linear deficit); hysteresis
   a direction effect beyond static maps, a slow mode and the adequate-order linear model (its
   test is conditional on them); saturation samples at a limit where the model, fitted without
   them, predicts beyond the limit, or where the input is further from its own rest level than
   elsewhere (a rest of the experiment at that level, where the input rests at its rest level, is
   not clipping).
4. **Held-out gain.** Each extension is fitted on the estimation records only; its gain is the
   simulation-fit difference on the validation records against its baseline, on the same
   samples (samples an extension rejects leave both sides). It is confirmed when the paired
   per-sample improvement is positive at one-sided 5 % (batch means, 20 batches,
   :func:`.stats.paired_gain_test`). drift and periodic_disturbance are disturbances, not
   input-output behaviour: their extensions track the measured output, and their gain is that
   of the corrected simulation plus the disturbance tracked from the measured output up to the
   previous sample (a one-step predictor) against the corrected simulation (records that carry
   their recording state: the drift beyond it simulated, each record's state refitted, see
   :func:`.extensions.drift`). outliers are glitches of the measurement: the extension is a robust refit
   and a one-step predictor that rejects glitches (its innovation clipped at the alpha/N band),
   against the corrected model's predictor with the same AR model reading every sample, on the
   samples the filter does not flag (a glitch carries into the reading predictor's next
   predictions; a persistent change does not return, so rejecting it loses).
5. A cause is **found** when its test is significant, its evidence agrees with its name and its
   held-out gain is confirmed. Found causes are ranked by :mod:`.ranking` (held-out gain; the
   simplest extension among overlapping gains); ``none`` follows them, then the rest by gain.
   The confidence of a found cause is (1 - p of its test) (1 - p of its held-out gain).

Fits are NRMSE fits (:func:`porosense.ident.fit_percent`, the function every command prints).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from porosense.diagnose import extensions, ranking, signals, stats
from porosense.diagnose.catalogue import CAUSES, EXPRESSIBLE, NONE
from porosense.diagnose.extensions import ADEQUATE, DYNAMICS, GENERIC
from porosense.dsp.blas import one_thread
from porosense.dsp.heap import reuses_freed_memory
from porosense.dsp.metrics import fit_percent, rms_percent
from porosense.errors import InputError
from porosense.files import write_text

#: causes that are disturbances, not input-output behaviour: tracked from the measured output
#: (drift, periodic_disturbance) or filtered out of it (outliers); their gain is a one-step
#: predictor's, ranked after the input-output causes
DISTURBANCES = ("drift", "periodic_disturbance", "outliers")


#: what a condition column can be (Record.column_kinds)
COLUMN_KINDS = ("input", "condition")


@dataclass
class Record:
    """One record to diagnose: what was measured and what the thing diagnosed predicted.

    Attributes
    ----------
    u : ndarray, shape (N, n_inputs)
        Inputs, in the model's input units (dR in % or dR/100).
    y : ndarray, shape (N,)
        Measured output, output units.
    yhat : ndarray, shape (N,)
        The prediction diagnosed (simulated from rest or at the rest level), output units.
    ts : float
        Sample period, s.
    conditions : dict of str to ndarray
        Extra columns of N samples (e.g. ``load_g`` in g, ``p_0`` in kPa) that the load and
        condition causes test.
    column_kinds : dict of str to str
        What a condition column is, where known: ``"input"`` (another channel's command, which
        can leak into the output additively: cross_coupling tests it) or ``"condition"`` (a
        measured condition such as a load, which can change the model's gain: load_dependence
        tests it). A column not named here is tested by both.
    state : porosense.diagnose.calibrate.StateColumns, optional
        The record's own recording state fitted into ``yhat`` (a calibrated simulation's), as
        nuisance regressors with their prior: every extension is fitted with it free to move
        within its prior (:meth:`.extensions.Context.fit_apply`).
    simulation : porosense.diagnose.calibrate.Simulation, optional
        The calibrated simulation ``yhat`` comes from (``--sim``): the causes the simulator carries
        as named effects are then tested and extended as that effect computed from it
        (:func:`.extensions.slow_relaxation`); without it, as residual regressions.

    Raises
    ------
    InputError
        Columns of different lengths, or fewer than 50 samples.
    """

    u: np.ndarray
    y: np.ndarray
    yhat: np.ndarray
    ts: float
    conditions: dict = field(default_factory=dict)
    column_kinds: dict = field(default_factory=dict)
    state: object = None
    simulation: object = None

    def __post_init__(self):
        self.u = np.asarray(self.u, float).reshape(len(self.u), -1)
        self.y = np.asarray(self.y, float)
        self.yhat = np.asarray(self.yhat, float)
        self.conditions = {k: np.asarray(v, float) for k, v in self.conditions.items()}
        bad = {k: v for k, v in self.column_kinds.items() if v not in COLUMN_KINDS or k not in self.conditions}
        if bad:
            raise InputError(f"column kinds {bad}: each must name a condition column and be one of {COLUMN_KINDS}")
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


def predict_at_rest_level(model, u: np.ndarray) -> np.ndarray:
    """``model``'s prediction for inputs ``u`` started settled at the record's rest level.

    Models simulate from rest (zero state). Each input is first held at its rest level
    (:func:`.signals.rest_level`: the first value of a record that starts on a hold, the mean of
    one that starts moving) for 10 time constants of the model's slowest pole (at least 50
    samples), which are simulated and dropped.

    Parameters
    ----------
    model : Model
        An identified model (``predict(u=...)``), one output.
    u : ndarray, shape (N, n_inputs) or (N,)
        Inputs, in the model's input units.

    Returns
    -------
    ndarray, shape (N,)
        The prediction, output units.
    """
    from porosense.ident.extended import settle_samples

    x = np.asarray(u, float).reshape(len(u), -1)
    n_pre = settle_samples(model)
    level = np.array([signals.rest_level(x[:, i]) for i in range(x.shape[1])])
    return np.asarray(model.predict(u=np.vstack([np.tile(level, (n_pre, 1)), x])), float)[n_pre:]


def predict_as_started(model, u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``model``'s prediction for a record, started in the state its first samples show.

    A record starts either settled at its inputs' rest level (a rest before it:
    :func:`predict_at_rest_level`) or at rest with its first level applied as a step at its first
    sample (a record that starts with the experiment: the model from zero state). Both are
    simulated, and the one closer to the measured output over the model's settling time (10 time
    constants of its slowest pole, at least 50 samples) is kept, as an estimated initial
    condition would be. A start assumed wrongly leaves a transient in the residual that the data
    do not have (on clean records of a second-order lag that start with a step it was named
    outliers).

    Parameters
    ----------
    model : Model
        An identified model (``predict(u=...)``), one output.
    u : ndarray, shape (N, n_inputs) or (N,)
        Inputs, in the model's input units.
    y : ndarray, shape (N,)
        The measured output, output units.

    Returns
    -------
    ndarray, shape (N,)
        The prediction, output units.
    """
    from porosense.ident.extended import settle_samples

    x = np.asarray(u, float).reshape(len(u), -1)
    y = np.asarray(y, float)
    settled = predict_at_rest_level(model, x)
    from_rest = np.asarray(model.predict(u=x), float)
    n = min(settle_samples(model), len(y))
    sse = [float(np.sum((y[:n] - p[:n]) ** 2)) for p in (settled, from_rest)]
    return settled if sse[0] <= sse[1] else from_rest


#: Baselines a gain is measured against (the names the report and JSON print).
BASELINES = {
    "nominal": "the nominal model",
    GENERIC: "the nominal model + G0 (generic linear correction)",
    ADEQUATE: "the corrected model (nominal + adequate-order linear correction + G0)",
}


@dataclass
class Finding:
    """One cause: its test, evidence, the gain of its extension on validation and against what.

    Attributes
    ----------
    cause : str
        Cause name (porosense.diagnose.CAUSES, or ``"none"``).
    confidence : float
        (1 - p of its test) (1 - p of its held-out gain) when found, else 0; for ``none``, 1 minus
        the best found cause's.
    statistic : str
        The test and its value, in words.
    evidence : str
        What the test, the evidence and the held-out gain showed, in sentences.
    extension : str
        The extension fitted for the cause.
    fit_before, fit_after : float
        NRMSE fit of the baseline and of the extension on the validation samples scored, %.
    gain : float
        fit_after - fit_before, points.
    baseline : str
        What the gain is measured against (a key of ``BASELINES``: ``"nominal"``, ``"generic"``,
        ``"adequate"``).
    gain_t, gain_p : float
        Batch-means t and one-sided p of the held-out improvement.
    confirmed : bool
        Whether the held-out improvement is positive at one-sided 5 %.
    n_params : int
        The extension's parameters beyond its baseline (what the ranking's simplicity rule counts).
    found : bool
        Test significant, evidence that agrees with the name and gain confirmed.
    rejected : str
        Why not found, when the test was significant.
    rms_before, rms_after : float
        RMS error of the baseline and the extension, % of max |y|.
    strength : float
        -log10 p of the cause's test.
    significant : bool
        Whether the test passed at alpha / K (and its gate).
    effect_to_noise : float
        SD of the cause's fitted terms over the SD of what remains of the residual.
    predictor_gain : float or None
        For a disturbance (drift, periodic_disturbance, outliers): the one-step predictor's gain, points.
    on_device : str
        Whether the firmware's estimator can express the extension.
    """

    cause: str
    confidence: float
    statistic: str
    evidence: str
    extension: str
    fit_before: float
    fit_after: float
    gain: float
    baseline: str = "adequate"
    gain_t: float = 0.0
    gain_p: float = 1.0
    confirmed: bool = False
    n_params: int = 0
    found: bool = False
    rejected: str = ""
    rms_before: float = float("nan")
    rms_after: float = float("nan")
    strength: float = 0.0
    significant: bool = False
    effect_to_noise: float = 0.0
    predictor_gain: float | None = None
    on_device: str = ""

    KEYS = (
        "cause",
        "confidence",
        "statistic",
        "evidence",
        "extension",
        "baseline",
        "fit_before",
        "fit_after",
        "gain",
        "gain_t",
        "gain_p",
        "confirmed",
        "n_params",
        "significant",
        "found",
        "rejected",
        "effect_to_noise",
        "predictor_gain",
        "on_device",
    )

    def to_dict(self) -> dict:
        """The JSON form: exactly the keys of the diagnosis report (``KEYS``).

        Returns
        -------
        dict
            Floats rounded to 4 decimals; a t or p that is not finite as None.
        """
        d = asdict(self)
        out = {k: (round(d[k], 4) if isinstance(d[k], float) and np.isfinite(d[k]) else d[k]) for k in self.KEYS}
        for k in ("gain_t", "gain_p"):
            if isinstance(out[k], float) and not np.isfinite(out[k]):
                out[k] = None
        return out

    def __str__(self) -> str:
        mark = "found" if self.found else ("rejected" if self.rejected else "")
        t = f"{self.gain_t:.3g}" if np.isfinite(self.gain_t) else "n/a"
        return (
            f"{self.cause:<21} {mark:<8} fit {self.fit_before:6.2f} -> {self.fit_after:6.2f} % "
            f"(gain {self.gain:+.2f} vs {self.baseline}, t = {t}; {self.n_params} parameters)  "
            f"{self.statistic}"
        )


@dataclass
class ModelFit:
    """A fit (%) and RMS (% of max |y|) on the validation samples, with what was scored."""

    what: str
    fit: float
    rms: float

    def to_dict(self) -> dict:
        return {"what": self.what, "fit": round(self.fit, 4), "rms": round(self.rms, 4)}


@dataclass
class Diagnosis:
    """Ranked findings (most likely first), the fits before and after, the dynamics verdict.

    Attributes
    ----------
    top : str
        The most likely cause (``"none"`` when no cause is found).
    findings : list of Finding
        Every cause, found ones first by held-out gain, then ``none``, then the rest by gain.
    residual_tests : dict
        Correlation tests of the nominal model's estimation residual (autocorrelation, input
        cross-correlation, Billings-Voon) at the per-cause alpha.
    curves : dict
        Series for the figures (residuals, predictions, spectrum), sampled at ``curves["ts"]`` s.
    ties : list of dict
        Overlapping gains: ``{"causes": [winner, other], "evidence": ...}``.
    extended : Model or None
        The top cause's extended model, when refitted.
    nominal : ModelFit or None
        Fit (%) and RMS (% of max |y|) of the nominal model on the validation records.
    corrected : ModelFit or None
        The same for the corrected model (nominal + adequate-order linear correction + G0).
    dynamics : dict
        The dynamics verdict: significant, found, correction_order (poles), gain_against_nominal
        (points), gain_t, data_order (poles) and a sentence.
    why_top : str
        Why the top cause was preferred over the runner-up, in one sentence.
    """

    top: str
    findings: list
    residual_tests: dict
    curves: dict = field(default_factory=dict, repr=False)
    ties: list = field(default_factory=list)
    extended: object = field(default=None, repr=False)
    nominal: ModelFit | None = None
    corrected: ModelFit | None = None
    dynamics: dict = field(default_factory=dict)
    why_top: str = ""

    def to_dict(self) -> dict:
        """The diagnosis report as a plain dict.

        Returns
        -------
        dict
            ``top``, ``nominal``, ``corrected``, ``dynamics``, ``why_top``, the ranking rule, the
            baselines, every finding (:meth:`Finding.to_dict`) and the ties.
        """
        return {
            "top": self.top,
            "nominal": self.nominal.to_dict() if self.nominal else None,
            "corrected": self.corrected.to_dict() if self.corrected else None,
            "dynamics": self.dynamics,
            "why_top": self.why_top,
            "ranking_rule": ranking.RULE,
            "baselines": BASELINES,
            "findings": [f.to_dict() for f in self.findings],
            "ties": self.ties,
        }

    def to_json(self, path) -> None:
        """Write :meth:`to_dict` as JSON (whole or not at all).

        Parameters
        ----------
        path : str or Path
            The JSON file.
        """
        write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")

    def finding(self, cause: str) -> Finding:
        """The finding of one cause.

        Parameters
        ----------
        cause : str
            Cause name.

        Returns
        -------
        Finding
            Its test, evidence and held-out gain.
        """
        return next(f for f in self.findings if f.cause == cause)

    def __str__(self) -> str:
        lines = []
        if self.nominal:
            lines.append(f"{self.nominal.what}: fit {self.nominal.fit:.2f} %, RMS {self.nominal.rms:.2f} %")
        if self.corrected:
            lines.append(f"{self.corrected.what}: fit {self.corrected.fit:.2f} %, RMS {self.corrected.rms:.2f} %")
        if self.dynamics.get("sentence"):
            lines.append(f"dynamics: {self.dynamics['sentence']}")
        lines.append(f"top: {self.top}" + (f" ({self.why_top})" if self.why_top else ""))
        lines += [f"  {f}" for f in self.findings]
        lines += [f"  overlap: {' / '.join(t['causes'])}: {t['evidence']}" for t in self.ties]
        return "\n".join(lines)

    def plot(self, directory) -> list:
        """Write the figures into a folder (see :mod:`porosense.diagnose.report`).

        Parameters
        ----------
        directory : str or Path
            Where to write them.

        Returns
        -------
        list of Path
            The figures written.
        """
        from porosense.diagnose import report

        return report.write_figures(self, directory)


def _effect_to_noise(ctx, Z: np.ndarray | None, scope: str) -> float:
    """SD of the fitted Z part of e_est ~ [baseline, Z] over the SD of what remains."""
    if Z is None or Z.shape[1] == 0:
        return 0.0
    X = np.column_stack([ctx.base(scope)[0], Z])
    coef = stats.lstsq(X, ctx.e_est)
    rest = ctx.e_est - X @ coef
    return float(np.std(Z @ coef[-Z.shape[1] :]) / (np.std(rest) or 1e-300))


def _n_params(cause: str, res, ctx) -> int:
    """Parameters the extension adds to its baseline: fitted coefficients, plus one per searched
    structural choice (a delay, a time constant, a side, a frequency)."""
    if "n_params" in res.detail:
        return int(res.detail["n_params"])
    if cause == "unmodelled_dynamics":
        return ctx.adequate.n_params
    if cause == "saturation":
        return 1  # the limit
    if cause == "outliers":
        return 1 + int(res.Z_est.shape[1])  # the rejection band, and one value per rejected sample
    k = 0 if res.Z_est is None else int(res.Z_est.shape[1])
    return k + (1 if res.n_search > 1 else 0)


def _one_dynamics_explanation(
    findings: dict, improvements: dict, extended: dict, y_val: np.ndarray, results: dict
) -> None:
    """unmodelled_dynamics, time_delay and slow_relaxation explain one linear deficit in
    different ways. A found time_delay explains it when the measured output prefers a dead
    time to one more pole on held-out data (one-sided 5 %, :func:`.dynamics.delay_or_pole`):
    what a higher-order correction gains is then the delay rendered by poles. A found slow_relaxation
    explains it when the pole the measured output needs beyond the nominal's is a slow one
    (one-sided 5 %, :func:`.dynamics.slow_pole`): a relaxation is a pole too, which a
    higher-order correction renders with more parameters. Otherwise the one with the largest gain
    explains it (:func:`.ranking.rank`), except that a specific cause (a slow mode: its own
    evidence, few parameters) wins an overlap with the generic correction (unmodelled_dynamics,
    the catch-all); another stays found only when its extension predicts the held-out data
    better than the winner's (one-sided 5 %)."""
    found = [c for c in DYNAMICS if findings[c].found]
    if len(found) < 2:
        return
    why = None
    if "time_delay" in found and results["time_delay"].detail.get("prefers_delay"):
        winner, why = "time_delay", "the measured output prefers a dead time to one more pole on held-out data"
    elif "slow_relaxation" in found and results["slow_relaxation"].detail.get("prefers_slow"):
        winner, why = (
            "slow_relaxation",
            "the pole the measured output needs beyond the nominal's is a slow one (one-sided 5 %)",
        )
    if why is not None:
        for c in found:
            if c != winner:
                f = findings[c]
                f.found, f.confidence = False, 0.0
                f.rejected = f"{winner} explains the same linear residual: {why}"
                f.evidence += f" Not found: {f.rejected}."
        return
    # the generic correction is the catch-all: it loses every overlap with a specific dynamic cause
    order, _ = ranking.rank(
        [
            ranking.Candidate(
                c, findings[c].gain, improvements[c], findings[c].n_params if c != "unmodelled_dynamics" else 10**6
            )
            for c in found
        ]
    )
    winner = order[0]
    for c in order[1:]:
        t = stats.paired_gain_test(y_val, extended[winner], extended[c])
        if not t.confirmed:
            f = findings[c]
            f.found, f.confidence = False, 0.0
            f.rejected = (
                f"{winner} explains the same linear residual: this extension does not predict the held-out "
                f"data better than {winner}'s (t = {t.t:.3g}, one-sided p = {t.p:.2g})"
            )
            f.evidence += f" Not found: {f.rejected}."


def _why(top: Finding, runner: Finding | None, step, findings: dict, improvements: dict) -> str:
    """Why the top cause was preferred over the runner-up, in one sentence."""
    if top.cause == NONE:
        if runner is None:
            return "no cause has a significant test"
        why = runner.rejected or "its test is not significant"
        return f"no cause is found; the strongest candidate, {runner.cause}, is not: {why}"
    if runner is None or not runner.found:
        other = (
            f"; the runner-up {runner.cause} is not found ({runner.rejected or 'test not significant'})"
            if runner is not None and runner.cause != NONE
            else ""
        )
        return f"the only cause found{other}"
    if runner.cause in DISTURBANCES and top.cause not in DISTURBANCES and runner.gain <= top.gain:
        return (
            f"the only input-output cause found; the disturbance {runner.cause} ({runner.gain:+.2f} points as a "
            "one-step predictor) is ranked after the input-output causes"
        )
    if runner.cause in DISTURBANCES and top.cause not in DISTURBANCES:
        return (
            f"input-output causes are ranked before disturbances: {runner.cause}'s gain ({runner.gain:+.2f} points, "
            f"against {top.gain:+.2f}) is a one-step predictor's, which reads the measured output (and a tracker "
            "follows any slow misfit the corrected model leaves), so it is not compared with a simulation's gain"
        )
    if step is not None and runner.cause in step.overlapping and top.n_params < runner.n_params:
        largest = findings[step.largest]
        return (
            f"gains overlap ({top.cause} {top.gain:+.2f}, {runner.cause} {runner.gain:+.2f} points; "
            f"{largest.cause}'s is not larger beyond its uncertainty) and {top.cause}'s extension is simpler "
            f"({top.n_params} against {runner.n_params} parameters)"
        )
    t = stats.mean_positive_test(improvements[top.cause] - improvements[runner.cause])
    if t.confirmed:
        return (
            f"larger held-out gain ({top.gain:+.2f} against {runner.gain:+.2f} points; difference batch-means "
            f"t = {t.t:.3g}, one-sided p = {t.p:.2g})"
        )
    return (
        f"larger or equal held-out gain ({top.gain:+.2f} against {runner.gain:+.2f} points) with no more "
        f"parameters ({top.n_params} against {runner.n_params})"
    )


@reuses_freed_memory
def diagnose(
    estimation: list, validation: list, *, alpha: float = stats.DEFAULT_ALPHA, nominal=None, refit: bool = True
) -> Diagnosis:
    """Diagnose predictions against measurements.

    Parameters
    ----------
    estimation, validation : list of Record
        Records with the nominal prediction ``yhat``; validation may repeat estimation when no
        held-out data exists (the gain is then in-sample).
    alpha : float
        Family-wise false-alarm level over the catalogue (each cause is tested at alpha / K).
    nominal : porosense.ident.Model, optional
        The identified model the predictions come from: the top cause's extension is then a
        model (re-identified or wrapped, see :mod:`.extend`) that can be saved and predicted.
    refit : bool
        Build that extended model (slow: a re-identification).

    Returns
    -------
    Diagnosis
        Ranked findings, the nominal and corrected fits on validation (%), the dynamics verdict.
    """
    if not estimation or not validation:
        raise InputError("diagnosis needs at least one estimation and one validation record")
    # many small least-squares problems: BLAS threads only add overhead (5x the CPU time measured)
    with one_thread():
        return _diagnose(estimation, validation, alpha, nominal, refit)


#: input-output causes whose extension, fitted beyond nominal + G0 alone, can render what the
#: adequate-order linear correction renders (a level map, a memory, a condition column, a clip);
#: see :func:`_explains_linear_deficit`
DEFICIT_EXPLAINERS = ("static_nonlinearity", "hysteresis", "load_dependence", "cross_coupling", "saturation")


def _explains_linear_deficit(estimation, validation, results, findings, alpha: float):
    """The first cause of DEFICIT_EXPLAINERS whose extension fitted beyond nominal + G0 alone
    predicts the held-out data as well as the same extension beyond the corrected model: the
    adequate-order correction adds nothing to it (its improvement is not positive at one-sided 5 %,
    batch means on the samples both score). A candidate is found beyond the corrected model, or
    its evidence there agrees with its name and it is not found (its test or its held-out gain
    beyond the correction fell short); such a one must have its test significant and gain beyond
    nominal + G0 alone (one-sided 5 %), where the second pass judges it. Returns (cause, test) or None."""
    plain = extensions.Context(estimation, validation, correct=False)
    y_val = plain.y_val
    for c in DEFICIT_EXPLAINERS:
        f = findings[c]
        # a cause found beyond the corrected model, or one whose evidence holds and whose test or
        # gain there fell short: the correction, fitted to the same estimation residual, can have
        # taken part of it (a hidden cause distorts the calibrated nominal, and a linear
        # correction then renders part of its effect on the estimation records only; hysteresis
        # at seed 1000 of the simulator trials: its test -log10 p = 32.5 beyond nominal + G0, 3.0
        # beyond the correction, below its level). It is judged below where it would be named
        evidence_ok = results[c].detail.get("evidence_ok", True)
        if not (f.found or evidence_ok):
            continue
        res = extensions.HANDLERS[c](plain, alpha)
        if res.yhat_val is None or results[c].yhat_val is None:
            continue
        keep = results[c].detail.get("score_mask", np.ones(len(y_val), bool))
        if not f.found:
            # it must gain beyond nominal + G0 alone, where it will be judged
            own = stats.paired_gain_test(y_val[keep], plain.baseline_validation(GENERIC)[keep], res.yhat_val[keep])
            if not (own.confirmed and res.gate and res.test.significant):
                continue
        t = stats.paired_gain_test(y_val[keep], res.yhat_val[keep], results[c].yhat_val[keep])
        if not t.confirmed:
            return c, t
    return None


def _diagnose(estimation, validation, alpha, nominal, refit, explained=None) -> Diagnosis:
    ctx = extensions.Context(estimation, validation)
    per_cause_alpha = alpha / len(CAUSES)
    y_val = ctx.y_val
    # dynamics first: the linear-dynamics causes against the nominal model
    results = {c: extensions.HANDLERS[c](ctx, per_cause_alpha) for c in DYNAMICS}
    ud = results["unmodelled_dynamics"]
    # not where its extra poles predict the held-out data worse than G0 alone (one-sided 5 %, the
    # evidence of :func:`.extensions.unmodelled_dynamics`): an order that fits the estimation
    # residual and not the validation would make every other cause's baseline worse
    corrected = bool(
        ud.test.significant
        and stats.paired_gain_test(y_val, ctx.yhat_val, ud.yhat_val).confirmed
        and ud.detail.get("evidence_ok", True)
        and explained is None
    )
    # every other cause is judged against the corrected model: the nominal + the adequate-order
    # linear correction when unmodelled_dynamics holds (test significant, held-out gain against
    # the nominal), the nominal itself otherwise; its level, direction and dynamics are the
    # corrected model's, so a too-low order cannot pass for a nonlinear cause
    ctx_nl = extensions.Context(*ctx.corrected(ADEQUATE), correct=False) if corrected else None
    if ctx_nl is None:
        ctx_nl = extensions.Context(estimation, validation, correct=False)
    results.update({c: extensions.HANDLERS[c](ctx_nl, per_cause_alpha) for c in CAUSES if c not in results})
    results = {c: results[c] for c in CAUSES}
    baselines = {"nominal": ctx.yhat_val, GENERIC: ctx.baseline_validation(GENERIC)}
    baselines[ADEQUATE] = ctx_nl.baseline_validation(GENERIC)
    findings, improvements, extended, compared = {}, {}, {}, {}
    for cause, res in results.items():
        cctx = ctx if cause in DYNAMICS else ctx_nl
        keep = res.detail.get("score_mask", np.ones(len(y_val), bool))
        trk = res.detail.get("predictor_val")
        if trk is not None:  # a one-step predictor against the corrected simulation (a disturbance
            # tracker) or against its own reading counterpart (the outlier filter)
            base_name, base, ext = ADEQUATE, res.detail.get("predictor_base_val", baselines[ADEQUATE]), trk
        else:
            base_name = "nominal" if cause in DYNAMICS else ADEQUATE
            base, ext = baselines[base_name], res.yhat_val if res.yhat_val is not None else baselines[ADEQUATE]
        fit0, fit1 = fit_percent(y_val[keep], base[keep]), fit_percent(y_val[keep], ext[keep])
        rms0, rms1 = rms_percent(y_val[keep], base[keep]), rms_percent(y_val[keep], ext[keep])
        confirm = stats.paired_gain_test(y_val[keep], base[keep], ext[keep])
        extended[cause] = np.where(keep, ext, np.nan)
        imp = np.full(len(y_val), np.nan)
        imp[keep] = (y_val[keep] - base[keep]) ** 2 - (y_val[keep] - ext[keep]) ** 2
        improvements[cause] = imp
        # what the ranking compares: each extension's held-out improvement over one common
        # reference, the nominal model (a disturbance's predictor over its own baseline): the
        # dynamics causes' gains are against the nominal, the others' against nominal + G0 (+ the
        # adequate-order correction), so their own gains differ by what that baseline gains
        com = np.full(len(y_val), np.nan)
        ref = base if trk is not None else baselines["nominal"]
        com[keep] = (y_val[keep] - ref[keep]) ** 2 - (y_val[keep] - ext[keep]) ** 2
        compared[cause] = com
        # evidence that agrees with the name
        notes = []
        if not res.detail.get("evidence_ok", True):
            notes.append(res.detail.get("evidence_note", "its evidence disagrees with its name"))
        own = None
        if res.detail.get("rival_val") is not None:
            own = stats.paired_gain_test(y_val[keep], res.detail["rival_val"][keep], ext[keep])
            if not own.confirmed:
                notes.append(
                    f"no held-out gain against {res.detail['rival']} (t = {own.t:.3g}, one-sided p = {own.p:.2g})"
                )
        if not confirm.confirmed:
            notes.append(f"its held-out gain is not confirmed (t = {confirm.t:.3g}, one-sided p = {confirm.p:.2g})")
        significant = bool(res.gate and res.test.significant)
        found = significant and not notes
        eff = _effect_to_noise(cctx, res.Z_est, GENERIC) if cause != "unmodelled_dynamics" else 0.0
        dropped = int((~keep).sum())
        baseline_text = BASELINES.get(base_name, base_name)
        sentence = (
            f"{res.test.sentence()}: {res.meaning}. Effect {eff:.3g} x the residual's noise. "
            f"On validation: {baseline_text} {fit0:.1f} %, extension ({res.extension}) {fit1:.1f} % "
            f"(gain {fit1 - fit0:+.2f} points, RMS {rms0:.2f} -> {rms1:.2f} %"
            + (f", {dropped} rejected samples left out of both" if dropped else "")
            + f"). {confirm.sentence()}."
            + (f" Against {res.detail['rival']}: {own.sentence()}." if own is not None else "")
            + (f" Not found: {'; '.join(notes)}." if significant and notes else "")
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
            baseline=base_name,
            gain_t=float(confirm.t),
            gain_p=float(confirm.p),
            confirmed=bool(confirm.confirmed),
            n_params=_n_params(cause, res, cctx),
            found=bool(found),
            rejected="; ".join(notes) if significant else "",
            rms_before=float(rms0),
            rms_after=float(rms1),
            strength=res.test.strength,
            significant=significant,
            effect_to_noise=float(eff),
            predictor_gain=float(fit1 - fit0) if trk is not None else None,
            on_device="expressible" if cause in EXPRESSIBLE else "not expressible",
        )
        if found:
            findings[cause].confidence = float(np.clip((1.0 - res.test.p) * (1.0 - confirm.p), 0.0, 1.0))
    if explained is not None:  # a nonlinear cause explains the linear deficit (second pass)
        f = findings["unmodelled_dynamics"]
        if f.found:
            c, t = explained
            f.found, f.confidence = False, 0.0
            f.rejected = (
                f"{c} explains the same linear residual: its extension beyond nominal + G0 alone predicts the "
                f"held-out data as well as beyond the corrected model (the correction's improvement t = {t.t:.3g}, "
                f"one-sided p = {t.p:.2g})"
            )
            f.evidence += f" Not found: {f.rejected}."
    elif corrected and findings["unmodelled_dynamics"].found:
        why = _explains_linear_deficit(estimation, validation, results, findings, per_cause_alpha)
        if why is not None:
            return _diagnose(estimation, validation, alpha, nominal, refit, explained=why)
    _one_dynamics_explanation(findings, improvements, extended, y_val, results)
    # input-output causes first; disturbances (tracked from the measured output, a predictor's
    # gain that a simulation gain cannot be compared with: see :mod:`.ranking`) after them
    groups = [[c for c in CAUSES if c not in DISTURBANCES], list(DISTURBANCES)]
    order, steps = [], []
    for group in groups:
        o, st = ranking.rank(
            [
                ranking.Candidate(c, findings[c].gain, compared[c], findings[c].n_params)
                for c in group
                if findings[c].found
            ]
        )
        order += o
        steps += st
    worst = max(results.values(), key=lambda r: r.test.strength).test
    threshold = -np.log10(per_cause_alpha)
    best_conf = max((findings[c].confidence for c in order), default=0.0)
    fit_adequate = fit_percent(y_val, baselines[ADEQUATE])
    findings[NONE] = Finding(
        NONE,
        float(1.0 - best_conf),
        f"largest test strength -log10 p = {worst.strength:.3g}",
        f"largest test strength -log10 p = {worst.strength:.3g} ({worst.name}), threshold "
        f"{threshold:.3g} (each cause at {100 * per_cause_alpha:.3g} %, {100 * alpha:g} % family-wise).",
        "none",
        float(fit_adequate),
        float(fit_adequate),
        0.0,
        baseline=ADEQUATE,
        gain_t=float("nan"),
        gain_p=float("nan"),
    )
    rest = sorted((c for c in CAUSES if c not in order), key=lambda c: (-findings[c].gain, c))
    ranked = [findings[c] for c in order] + [findings[NONE]] + [findings[c] for c in rest]
    top = ranked[0]
    runner = ranked[1] if top.cause != NONE else next((f for f in ranked[1:] if f.significant), None)
    why = _why(top, runner, steps[0] if steps else None, findings, compared)
    larger = [c for c in DISTURBANCES if findings[c].found and findings[c].gain > top.gain and top.cause != NONE]
    if larger and top.cause not in DISTURBANCES and runner is not None and runner.cause not in DISTURBANCES:
        why += (
            f"; {', '.join(larger)} gains more ({', '.join(f'{findings[c].gain:+.2f}' for c in larger)} points) "
            "as a one-step predictor, which reads the measured output, so it is ranked after the input-output "
            "causes"
        )
    ties = []
    if steps:
        for other in steps[0].overlapping:
            if other != steps[0].winner:
                t = stats.mean_positive_test(compared[steps[0].largest] - compared[other])
                ties.append(
                    {
                        "causes": [steps[0].winner, other],
                        "evidence": f"{other}'s held-out improvement is not below {steps[0].largest}'s "
                        f"(t = {t.t:.3g}, one-sided p = {t.p:.2g}); the simpler extension is ranked first",
                    }
                )
    ud = findings["unmodelled_dynamics"]
    dyn = {
        "significant": ud.significant,
        "found": ud.found,
        "correction_order": int(ctx.adequate.order),
        "gain_against_nominal": round(ud.gain, 4),
        "gain_t": round(ud.gain_t, 4) if np.isfinite(ud.gain_t) else None,
    }
    if ud.found:
        data_order = _data_order(ctx)
        dyn["data_order"] = data_order
        dyn["sentence"] = (
            f"the nominal dynamics are too simple: the residual needs a linear correction of "
            f"{ctx.adequate.order} poles (gain {ud.gain:+.2f} points against the nominal model, t = {ud.gain_t:.3g}); "
            f"a linear model of the data alone needs {data_order} poles (BIC, output error). The other causes are "
            "judged beyond the corrected model"
        )
    else:
        dyn["sentence"] = (
            "the nominal dynamics are adequate (unmodelled_dynamics "
            + ("not significant" if not ud.significant else f"not found: {ud.rejected}")
            + "); the other causes are judged beyond the corrected model"
        )
    fit_nom = fit_percent(y_val, ctx.yhat_val)
    diag = Diagnosis(
        top.cause,
        ranked,
        ctx.residual_tests(per_cause_alpha),
        ctx.curves(results),
        ties,
        nominal=ModelFit("nominal model on the validation records", fit_nom, rms_percent(y_val, ctx.yhat_val)),
        corrected=ModelFit(
            (
                f"corrected model (nominal + a linear correction of {ctx.adequate.order} poles + G0)"
                if corrected
                else "corrected model (nominal + G0: the nominal dynamics are adequate)"
            )
            + " on the validation records",
            fit_adequate,
            rms_percent(y_val, baselines[ADEQUATE]),
        ),
        dynamics=dyn,
        why_top=why,
    )
    if nominal is not None and refit and order:
        from porosense.diagnose import extend

        extend.attach(diag, ctx, results, nominal, baselines)
    return diag


def _data_order(ctx) -> int:
    """Poles of a linear output-error model of the measured output alone (the order the data support)."""
    from porosense.diagnose import dynamics

    return int(dynamics.choose([r.u for r in ctx.est], [r.y for r in ctx.est]).order)
