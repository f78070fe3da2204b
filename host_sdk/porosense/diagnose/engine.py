"""Diagnosis: residual tests -> named causes -> extensions refitted -> gain on validation.

The thing diagnosed (a calibrated simulation, an identified model, any predictor) enters only
through its predictions ``yhat`` on the estimation and validation records, so the same engine
serves ``--sim``, ``--model`` and ``--baseline``.

Every extension is the original prediction plus a correction fitted on the estimation part:
a generic linear correction G0 (a Laguerre filter bank of every used input, at the model's
own dominant pole, and a constant) and the cause's own terms (see :mod:`.extensions`). A cause
is *found* when its test, conditional on G0, is significant at alpha / 10 (alpha = 1 %
family-wise over the ten causes: Bonferroni) and its extension improves the validation fit by
more than ``min_gain`` points. Found causes are ranked by the strength (-log10 p) of their test;
tests of causes that mimic each other (static map, hysteresis, slow mode, drift) are each
conditional on the others' regressors, so that the strength measures what only that cause
explains.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from porosense.diagnose import extensions, stats
from porosense.diagnose.catalogue import CAUSES, NONE
from porosense.diagnose.metrics import fit_percent, rms_percent
from porosense.errors import InputError


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

    def to_dict(self) -> dict:
        """The JSON form: exactly the keys of the diagnosis report."""
        keys = ("cause", "confidence", "statistic", "evidence", "extension", "fit_before", "fit_after", "gain")
        d = asdict(self)
        return {k: (round(d[k], 4) if isinstance(d[k], float) else d[k]) for k in keys}

    def __str__(self) -> str:
        return (f"{self.cause:<21} conf {self.confidence:.2f}  fit {self.fit_before:6.2f} -> "
                f"{self.fit_after:6.2f} % (gain {self.gain:+.2f})  {self.statistic}")


@dataclass
class Diagnosis:
    """Ranked findings (most likely first), the residual statistics and what plots need."""

    top: str
    findings: list
    residual_tests: dict
    curves: dict = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        return {"top": self.top, "findings": [f.to_dict() for f in self.findings]}

    def to_json(self, path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    def finding(self, cause: str) -> Finding:
        return next(f for f in self.findings if f.cause == cause)

    def __str__(self) -> str:
        lines = [f"top: {self.top}"] + [f"  {f}" for f in self.findings]
        return "\n".join(lines)

    def plot(self, directory) -> list:
        """Write the figures into ``directory``; returns their paths (see :mod:`.report`)."""
        from porosense.diagnose import report

        return report.write_figures(self, directory)


def _confidences(strengths: dict, qualified: dict, threshold: float) -> dict:
    """Map test strengths to 0..1 confidences, ordered like the ranking.

    A found cause gets (1 - 10^-(s - t)) times its share of the found strength; causes not
    found get at most 0.5 * min(found) (or their own significance when nothing is found).
    """
    found = {c: s for c, s in strengths.items() if qualified[c]}
    total = sum(found.values()) or 1.0
    conf = {}
    for c, s in found.items():
        conf[c] = (1.0 - 10.0 ** (-(s - threshold))) * (0.5 + 0.5 * s / total)
    ceiling = 0.5 * min(conf.values()) if conf else 0.49
    for c, s in strengths.items():
        if c not in found:
            conf[c] = ceiling * min(1.0, s / threshold) * 0.99 if threshold > 0 else 0.0
    conf[NONE] = 1.0 - max(conf.values()) if found else 1.0 - max(conf.values(), default=0.0)
    if found:
        conf[NONE] = min(conf[NONE], ceiling)
    return conf


def diagnose(estimation: list, validation: list, *, alpha: float = stats.DEFAULT_ALPHA,
             min_gain: float = 0.05) -> Diagnosis:
    """Diagnose predictions against measurements.

    estimation, validation: lists of :class:`Record` (validation may repeat estimation if no
    held-out data exists, then the gain is in-sample). alpha: family-wise false-alarm level
    over the catalogue (each cause is tested at alpha / 10). min_gain: fit points an extension
    must add on validation beyond the generic linear correction to count.
    """
    if not estimation or not validation:
        raise InputError("diagnosis needs at least one estimation and one validation record")
    ctx = extensions.Context(estimation, validation)
    per_cause_alpha = alpha / len(CAUSES)
    y_val = np.concatenate([r.y for r in validation])
    yhat_val = np.concatenate([r.yhat for r in validation])
    fit0, rms0 = fit_percent(y_val, yhat_val), rms_percent(y_val, yhat_val)

    results = {}
    for cause in CAUSES:
        results[cause] = extensions.HANDLERS[cause](ctx, per_cause_alpha)

    strengths, qualified, findings = {}, {}, {}
    threshold = -np.log10(per_cause_alpha)
    for cause, res in results.items():
        pred = res.yhat_val
        keep = res.detail.get("score_mask", slice(None))
        fit1 = fit_percent(y_val[keep], pred[keep]) if pred is not None else fit0
        rms1 = rms_percent(y_val[keep], pred[keep]) if pred is not None else rms0
        # the test is already conditional on the generic linear correction G0; on validation the
        # extension must beat the original prediction
        incremental = fit1 - fit0
        strengths[cause] = res.test.strength if res.gate else min(res.test.strength, threshold * 0.99)
        qualified[cause] = bool(res.gate and res.test.significant and incremental > min_gain)
        sentence = (f"{res.test.sentence()}: {res.meaning}. The extension ({res.extension}) changes the "
                    f"validation fit from {fit0:.1f} % to {fit1:.1f} % and the RMS from {rms0:.2f} % "
                    f"to {rms1:.2f} %.")
        findings[cause] = Finding(cause, 0.0, f"{res.test.name} = {res.test.value:.4g}", sentence,
                                  res.extension, float(fit0), float(fit1), float(fit1 - fit0), float(rms0),
                                  float(rms1), strengths[cause], qualified[cause])
    # Clipping is a static nonlinearity of one specific kind: when samples pile up at a limit,
    # the level dependence it causes is evidence for saturation, not for a smooth nonlinearity.
    if qualified["saturation"]:
        strengths["saturation"] += strengths["static_nonlinearity"]
    # Likewise a measured load that changes during the record shifts the level map (where along
    # its stroke the actuator collapses): the level and direction dependence that follows is
    # evidence for the load, which a measured column explains and a static map cannot -- when
    # the load's extension predicts the validation data better than those causes' extensions.
    rivals = ("static_nonlinearity", "hysteresis")
    if qualified["load_dependence"] and all(findings["load_dependence"].gain > findings[c].gain for c in rivals):
        strengths["load_dependence"] += max(strengths[c] for c in rivals)
    conf = _confidences(strengths, qualified, threshold)
    worst = max(results.values(), key=lambda r: r.test.strength).test
    findings[NONE] = Finding(
        NONE, 0.0, f"largest test strength -log10 p = {worst.strength:.3g}",
        f"largest test strength -log10 p = {worst.strength:.3g} ({worst.name}), threshold "
        f"{threshold:.3g} (each cause at {100 * per_cause_alpha:g} %, {100 * alpha:g} % family-wise).",
        "none", float(fit0), float(fit0), 0.0, float(rms0), float(rms0), 0.0, False)
    for c, f in findings.items():
        f.confidence = float(np.clip(round(conf[c], 4), 0.0, 1.0)) + 0.0
    order = sorted(findings.values(), key=lambda f: (-f.confidence, f.cause))
    residual_tests = ctx.residual_tests(per_cause_alpha)
    curves = ctx.curves(results)
    return Diagnosis(order[0].cause, order, residual_tests, curves)
