"""Diagnosis benchmark on the independent hidden-effect generator (:mod:`.hidden_effects`).

Per trial: the nominal linear output-error model is identified at ``trial.nominal_order`` on
the estimation record with the project's own identification (:class:`porosense.ident.Linear`,
``nominal_order - 1`` zeros and the one-sample delay of a sampled continuous system), both
records are predicted, and diagnosis runs with ``u_aux`` and ``load`` offered as condition
columns. The top-ranked cause is compared with ``trial.expected``.

Reported: top-1 rate per cause, the false-alarm rate (clean kinds whose top is not ``none``),
the mean held-out gain of the top finding (fit points on the validation record against the
cause's baseline: the nominal model for unmodelled_dynamics, time_delay and slow_relaxation,
the corrected model for the others; the regressor extension's gain, since the re-identified
extended model that ``porosense diagnose --save-extended`` builds is left out to keep the bench
quick) and the CPU and wall seconds per trial with the load average.

Seeds: the bench uses ``BENCH_SEED``, ``BENCH_SEED + 1``, ...; development work looks only at
``DEV_SEED`` onwards, so the figures come from data the detector was not tuned on.
small: 2 trials per kind (CI); full: 10 trials per kind (the figure in docs/figures.md).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from porosense import ident
from porosense.bench import hidden_effects as he
from porosense.diagnose import Record, diagnose

BENCH_SEED = 20261124
DEV_SEED = 7000
KINDS = he.CAUSES + he.FALSE_ALARM_KINDS
DYNAMICS = ("unmodelled_dynamics", "time_delay", "slow_relaxation")
SIZES = {"small": 2, "full": 10}


def _slowest_tau_samples(model) -> float:
    """Time constant (samples) of the slowest pole of the model's linear blocks."""
    chain = model.output_chain()
    worst = 0.0
    for br in chain.branches:
        _, a = br.h1.to_tf()
        r = np.abs(np.roots(np.atleast_1d(a))) if len(np.atleast_1d(a)) > 1 else np.zeros(0)
        if r.size:
            worst = max(worst, float(np.max(r)))
    return -1.0 / np.log(worst) if 0 < worst < 1 else 1.0


def _preroll(x: np.ndarray, n: int) -> np.ndarray:
    x = np.asarray(x, float)
    x = x[:, None] if x.ndim == 1 else x
    return np.vstack([np.repeat(x[:1], n, axis=0), x])


def predict_settled(model, u: np.ndarray, n_pre: int) -> np.ndarray:
    """Prediction of ``model`` started in steady state at u[0]: u[0] held for n_pre samples first.

    The project's models simulate from rest (zero state); a record that starts at a non-zero
    level would otherwise begin with a start-up transient that is not in the data.
    """
    return model.predict(u=_preroll(u, n_pre))[n_pre:]


def fit_nominal(u: np.ndarray, y: np.ndarray, ts: float, order: int):
    """(model, pre-roll samples): Linear OE of ``order`` poles on a record that starts settled.

    The record is prefixed by its first input held for n_pre samples (simulated, not scored:
    ``skip``), n_pre at least 10 time constants of the identified model's slowest pole.
    """

    n_pre = 200
    for _ in range(3):
        m = ident.make_model("linear", n_poles=order, n_zeros=max(order - 1, 0), delay=1, skip=n_pre)
        m.fit(u=[_preroll(u, n_pre)], y=[np.concatenate([np.full(n_pre, y[0]), y])], ts=ts)
        need = int(np.ceil(10 * _slowest_tau_samples(m)))
        if need <= n_pre:
            break
        n_pre = min(need, 20000)
    return m, n_pre


@dataclass
class TrialResult:
    """Outcome of one bench trial."""

    kind: str
    seed: int
    expected: str
    top: str
    gain: float
    seconds: float
    diagnosis: object = None

    @property
    def correct(self) -> bool:
        return self.top == self.expected


def diagnose_trial(trial, **kwargs):
    """Identify the nominal model on ``trial`` and diagnose it; returns the Diagnosis."""

    est, val = trial.estimation, trial.validation
    model, n_pre = fit_nominal(est["u"], est["y"], trial.ts, trial.nominal_order)
    records = []
    for part in (est, val):
        yhat = predict_settled(model, part["u"], n_pre)
        cond = {c: part[c] for c in trial.condition_columns}
        records.append([Record(part["u"], part["y"], yhat, trial.ts, cond)])
    return diagnose(records[0], records[1], nominal=model, **{"refit": False, **kwargs})


def run_trial(kind: str, seed: int) -> TrialResult:
    """Draw (kind, seed), diagnose it and score the top cause."""
    trial = he.draw_trial(kind, seed)
    t0 = time.perf_counter()
    d = diagnose_trial(trial)
    gain = d.findings[0].gain if d.top != "none" else 0.0
    return TrialResult(kind, seed, trial.expected, d.top, float(gain), time.perf_counter() - t0, d)


def run_counts(n: int, seed: int = BENCH_SEED, kinds=KINDS) -> dict:
    """:func:`run` with ``n`` trials per kind (the result carries the counts: trials, correct)."""
    return _run(n, seed, kinds)


def run(size: str, seed: int = BENCH_SEED, kinds=KINDS) -> dict:
    """Top-1 per cause and false-alarm rate over ``SIZES[size]`` trials per kind."""
    return _run(SIZES.get(size, SIZES["small"]), seed, kinds)


def _run(n: int, seed: int, kinds) -> dict:
    t0 = time.perf_counter()
    c0 = time.process_time()
    results = [run_trial(kind, seed + k) for kind in kinds for k in range(n)]
    by_kind = {k: [r for r in results if r.kind == k] for k in kinds}
    causes = [k for k in kinds if k in he.CAUSES]
    clean = [k for k in kinds if k in he.FALSE_ALARM_KINDS]
    top1 = {k: sum(r.correct for r in by_kind[k]) / n for k in causes}
    hits = [r for k in causes for r in by_kind[k]]
    overall = sum(r.correct for r in hits) / max(len(hits), 1)
    clean_runs = [r for k in clean for r in by_kind[k]]
    false_alarm = sum(not r.correct for r in clean_runs) / max(len(clean_runs), 1)
    gains = {k: float(np.mean([r.gain for r in by_kind[k] if r.correct] or [float("nan")])) for k in causes}
    misses = [f"{r.kind} seed {r.seed}: named {r.top}" for r in results if not r.correct]
    out = {
        "generator": "porosense.bench.hidden_effects (independent of the detector)",
        "trials": len(results),
        "correct": sum(r.correct for r in results),
        "seeds": f"{seed}..{seed + n - 1} for every kind",
        "trials_per_kind": n,
        "top1_rate": top1,
        "top1_overall": overall,
        "false_alarm_rate": false_alarm,
        "false_alarm_by_kind": {k: sum(not r.correct for r in by_kind[k]) / n for k in clean},
        "mean_gain_points": gains,
        "misses": misses,
        "seconds_per_trial": round((time.perf_counter() - t0) / max(len(results), 1), 2),
        "cpu_seconds_per_trial": round((time.process_time() - c0) / max(len(results), 1), 2),
        "load_average": round(os.getloadavg()[0], 1),
    }
    out["summary"] = (
        [
            f"{c:<21} top-1 {100 * top1[c]:5.1f} %  mean gain {gains[c]:+6.2f} fit points (held out, "
            f"{'vs nominal' if c in DYNAMICS else 'vs the corrected model'})"
            for c in causes
        ]
        + [
            f"all causes: top-1 {100 * overall:.1f} % of {len(hits)} trials" if hits else "no cause trials",
            (
                f"clean data: top is not none in {100 * false_alarm:.1f} % of {len(clean_runs)} trials "
                + ", ".join(f"{k} {100 * v:.0f} %" for k, v in out["false_alarm_by_kind"].items())
            )
            if clean_runs
            else "no clean trials",
            f"seeds {out['seeds']}; {out['cpu_seconds_per_trial']} s CPU per trial ({out['seconds_per_trial']} s "
            f"wall at load average {out['load_average']})",
        ]
        + [f"miss: {m}" for m in misses]
    )
    return out
