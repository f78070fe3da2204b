"""The paper's analyses as plain functions on arrays and models (no figures, no files).

- :func:`compare` -- a model scored on recordings: fit (%) and RMS (% of max |y|) per file and
  output, mean and standard error over the files (MATLAB's ``compare`` over a data set).
- :func:`hold_averages` -- mean of columns over the settled part of each pressure hold.
- :func:`fit_exponential` -- y = a exp(b x) with R^2 (the paper's fit of g's breakpoints).
- :func:`hysteresis_branches` -- loading and unloading branches of a loop, each fitted.
- :func:`poles_zeros` -- discrete poles and zeros of every linear block (Table S2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from porosense.errors import InputError
from porosense.ident.scoring import model_outputs, simulation_fit
from porosense.report.figures import mean_and_se


@dataclass
class CompareResult:
    """Scores of one model on several recordings. ``fit[file][output]`` and ``rms[...]`` in %."""

    model: str
    files: list[str]
    outputs: list[str]
    fit: dict
    rms: dict
    predictions: dict = field(default_factory=dict, repr=False)  # file -> (N, n_outputs)

    def summary(self, output: str) -> dict:
        """Mean and standard error over the files of fit and RMS (%) for ``output``."""
        fm, fs = mean_and_se([self.fit[f][output] for f in self.files])
        rm, rs = mean_and_se([self.rms[f][output] for f in self.files])
        return {"fit_mean": fm, "fit_se": fs, "rms_mean": rm, "rms_se": rs, "files": len(self.files)}

    def lines(self) -> list[str]:
        out = []
        for o in self.outputs:
            out.append(f"{o}: {'file':<40} {'fit %':>8} {'RMS %':>8}")
            for f in self.files:
                out.append(f"{'':{len(o) + 2}}{f[-40:]:<40} {_num(self.fit[f][o]):>8} {_num(self.rms[f][o]):>8}")
            s = self.summary(o)
            out.append(
                f"{'':{len(o) + 2}}{'mean ± standard error':<40} {_mean_se(s['fit_mean'], s['fit_se']):>8}"
                f" {_mean_se(s['rms_mean'], s['rms_se'])}"
            )
        out.append("each file simulated from rest (zero initial state); fit: NRMSE, RMS: % of max |output|")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "files": self.files,
            "outputs": self.outputs,
            "per_file": [
                {"file": f, **{o: {"fit": self.fit[f][o], "rms": self.rms[f][o]} for o in self.outputs}}
                for f in self.files
            ],
            "summary": {o: self.summary(o) for o in self.outputs},
        }


def compare(model, tables, name: str = "model") -> CompareResult:
    """Simulate ``model`` from rest on each table and score every output the table holds
    (:func:`porosense.ident.simulation_fit`, the one fit every command prints).

    Raises InputError when a table lacks an input or an output, or holds non-finite cells.
    """
    outputs = model_outputs(model)
    fit, rms, preds, files = {}, {}, {}, []
    for table in tables:
        key = str(table.path)
        if len(table) < 2:
            raise InputError(f"{table.path}: {len(table)} samples; a comparison needs at least 2")
        missing = [c for c in list(model.inputs) + outputs if c not in table.columns]
        if missing:
            raise InputError(f"{table.path}: no column(s) {', '.join(missing)} (columns: {', '.join(table.names)})")
        table.require_finite(list(model.inputs) + outputs)
        u = np.column_stack([table.columns[c] for c in model.inputs])
        y = np.column_stack([table.columns[o] for o in outputs])
        scored = simulation_fit(model, u, y, outputs=outputs)
        fit[key], rms[key], preds[key] = scored.fit, scored.rms, scored.yhat
        files.append(key)
    return CompareResult(name, files, outputs, fit, rms, preds)


def hold_averages(pressure_kpa, columns: dict, *, settle: float = 0.5, min_samples: int = 5) -> list[dict]:
    """Per hold of a piecewise-constant pressure command (kPa, non-zero levels only): the level and
    the mean of each column over the last ``1 - settle`` fraction of the hold.

    Holds shorter than ``2 * min_samples`` samples are skipped. Returns
    ``[{"pressure_kpa": p, "n": samples, col: mean, ...}, ...]`` in time order.
    """
    p = np.asarray(pressure_kpa, dtype=float)
    edges = np.flatnonzero(np.diff(p) != 0) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [len(p)]])
    holds = []
    for a, b in zip(starts, stops):
        if p[a] == 0 or b - a < 2 * min_samples:
            continue
        k0 = a + int(settle * (b - a))
        holds.append(
            {
                "pressure_kpa": float(p[a]),
                "n": int(b - k0),
                **{name: float(np.mean(np.asarray(v, dtype=float)[k0:b])) for name, v in columns.items()},
            }
        )
    return holds


def r_squared(y, yhat) -> float:
    y, yhat = np.asarray(y, float), np.asarray(yhat, float)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum((y - yhat) ** 2)) / ss_tot if ss_tot > 0 else float("nan")


def fit_exponential(x, y) -> tuple[float, float, float]:
    """Least-squares y = a exp(b x); returns (a, b, R^2). Started from a log-linear fit."""
    from scipy import optimize

    x, y = np.asarray(x, float), np.asarray(y, float)
    sign = np.sign(np.mean(y)) or 1.0
    ok = sign * y > 0
    if ok.sum() >= 2:
        b0, loga = np.polyfit(x[ok], np.log(sign * y[ok]), 1)
        a0 = sign * np.exp(loga)
    else:
        a0, b0 = float(np.mean(y)) or 1.0, 0.0
    scale = max(np.ptp(x), 1e-12)
    sol = optimize.least_squares(lambda q: q[0] * np.exp(q[1] / scale * x) - y, [a0, b0 * scale])
    a, b = float(sol.x[0]), float(sol.x[1] / scale)
    return a, b, r_squared(y, a * np.exp(b * x))


def hysteresis_branches(x, y, *, degree: int = 3, smooth: int = 5, load=None) -> dict:
    """Split a loop into loading and unloading and fit a polynomial of ``degree`` to each:
    ``{direction: {"coef", "r2", "x", "y"}}`` with (x, y) the fitted curve.

    Loading is ``load`` rising (default: x rising). For a vacuum actuator pass the applied vacuum
    (minus the gauge pressure command) or the output: its resistance falls as it is loaded, so
    "dR rising" is its unloading. The direction comes from the sign of the slope of ``load``
    smoothed over ``smooth`` samples; samples where it stands still are left out.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    drive = x if load is None else np.asarray(load, float)
    xs = np.convolve(drive, np.ones(smooth) / smooth, mode="same")
    dx = np.gradient(xs)
    moving = np.abs(dx) > 1e-3 * max(np.ptp(drive), 1e-12) / max(smooth, 1)
    out = {}
    for name, mask in (("loading", moving & (dx > 0)), ("unloading", moving & (dx < 0))):
        if mask.sum() <= degree + 2:
            continue
        coef = np.polyfit(x[mask], y[mask], degree)
        grid = np.linspace(x[mask].min(), x[mask].max(), 100)
        out[name] = {
            "coef": coef.tolist(),
            "r2": r_squared(y[mask], np.polyval(coef, x[mask])),
            "x": grid,
            "y": np.polyval(coef, grid),
            "samples": int(mask.sum()),
        }
    return out


def poles_zeros(model) -> list[dict]:
    """Every linear block of every output: discrete poles and zeros, and the time constants (s)
    of the real poles (tau = -Ts / ln z)."""
    rows = []
    for m in getattr(model, "models", [model]):
        for name, tf in m.linear_blocks().items():
            poles = np.asarray(tf.poles())
            zeros = np.asarray(tf.zeros())
            # Second-order sections pad a first-order block with a pole and a zero at z = 0 that
            # cancel: neither is dynamics. Poles left at the origin are delays, zeros there advances.
            at_origin = int(min(np.sum(np.abs(poles) < 1e-9), np.sum(np.abs(zeros) < 1e-9)))
            if at_origin:
                poles = np.delete(poles, np.argsort(np.abs(poles))[:at_origin])
            zeros = zeros[np.abs(zeros) > 1e-12]  # the z^-k delays are not zeros of the dynamics
            real = poles[(np.abs(poles.imag) < 1e-9) & (poles.real > 0) & (poles.real < 1)].real
            rows.append(
                {
                    "output": m.output,
                    "kind": m.kind,
                    "block": name,
                    "poles": poles.tolist(),
                    "zeros": zeros.tolist(),
                    "time_constants_s": sorted((-m.ts / np.log(real)).tolist()),
                }
            )
    return rows


def format_roots(values, digits: int = 4) -> str:
    """'0.9512, 0.80±0.12j' style text of complex roots (conjugate pairs once)."""
    parts, seen = [], []
    for v in values:
        v = complex(v)
        if any(abs(v.conjugate() - s) < 1e-9 for s in seen):
            continue
        seen.append(v)
        parts.append(f"{v.real:.{digits}f}" if abs(v.imag) < 1e-9 else f"{v.real:.{digits}f}±{abs(v.imag):.{digits}f}j")
    return ", ".join(parts) or "none"


def _num(value: float) -> str:
    """A fit or RMS (%) with 2 decimals; 'n/a' where there is none (a constant output has no fit)."""
    return f"{value:.2f}" if math.isfinite(value) else "n/a"


def _mean_se(mean: float, se: float) -> str:
    return f"{mean:.2f}±{se:.2f}" if math.isfinite(mean) and math.isfinite(se) else _num(mean)
