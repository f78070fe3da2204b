"""Extended models that the on-device structure cannot carry: a nominal model plus named terms.

Diagnosis extends a model by the cause it names. Where the extension fits the estimator
structure (a static map, a delay, extra poles, another input) it is an ordinary identified
model (:mod:`porosense.ident.models`). Where it does not (hysteresis, a load-scheduled gain,
drift, a periodic disturbance, outlier rejection) it is an :class:`ExtendedModel`: the nominal
model's simulation plus a linear combination of terms computed from the inputs, the extra
columns and the nominal output, all from the recording alone (simulation, never the measured
output). It is saved, loaded and predicted like any model file; quantising it is refused with
the reason and what to do instead.

File format: ``{"format": "porosense.ident.extended", "version": 1, "cause", "nominal": <model
dict>, "columns": [extra input names], "terms": [...], "coef": [...], "preroll", "note"}``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from porosense.dsp import laguerre_bank, play_operator
from porosense.errors import InputError, ModelError
from porosense.files import write_text
from porosense.ident.models import Model

FORMAT = "porosense.ident.extended"
FORMAT_VERSION = 1


# -- terms ---------------------------------------------------------------------------------------


def term_columns(term: dict, u: np.ndarray, yhat: np.ndarray, ts: float) -> np.ndarray:
    """Columns (N, k) of one term. u: (N, n_inputs + n_columns) in the model's input order."""
    kind = term["type"]
    n = len(yhat)
    if kind == "const":
        return np.ones((n, 1))
    if kind == "laguerre":
        return laguerre_bank(u[:, term["input"]], term["pole"], term["order"], settled=True)
    if kind == "play_output":
        return (play_operator(yhat, term["radius"]) - yhat)[:, None]
    if kind == "play_input":
        i = term["input"]
        d = play_operator(u[:, i], term["radius"]) - u[:, i]
        return laguerre_bank(d, term["pole"], term["order"], settled=True)
    if kind == "hinge_output":
        return np.maximum(0.0, yhat[:, None] - np.asarray(term["knots"], float)[None, :])
    if kind == "output":
        return yhat[:, None]
    if kind == "column":
        return ((u[:, term["input"]] - term["lo"]) / term["scale"])[:, None]
    if kind == "column_times_output":
        c = (u[:, term["input"]] - term["lo"]) / term["scale"]
        cols = [c * (yhat - term["mean"]) / term["sd"]]
        cols += [c * np.maximum(0.0, yhat - k) / term["sd"] for k in term.get("knots", [])]
        return np.column_stack(cols)
    if kind == "time":
        t = np.arange(n) * ts
        return np.column_stack([t, t * yhat])
    raise ModelError(f"extended model: unknown term type {kind!r}")


def design(terms: list, u: np.ndarray, yhat: np.ndarray, ts: float) -> np.ndarray:
    """All terms' columns side by side."""
    return np.column_stack([term_columns(t, u, yhat, ts) for t in terms])


def settle_samples(model) -> int:
    """Samples for the model to settle: 10 time constants of its slowest pole (at least 50)."""
    worst = 0.0
    for br in model.output_chain().branches:
        _, a = br.h1.to_tf()
        a = np.atleast_1d(a)
        if len(a) > 1:
            worst = max(worst, float(np.max(np.abs(np.roots(a)))))
    if not 0 < worst < 1:
        return 50
    return int(min(20000, max(50, np.ceil(-10.0 / np.log(worst)))))


def predict_settled(model, u: np.ndarray, n_pre: int | None = None) -> np.ndarray:
    """``model``'s prediction started in steady state at u[0] (u[0] held for n_pre samples first).

    Models simulate from rest (zero state); a recording that starts at a non-zero level would
    otherwise begin with a start-up transient that is not in the data.
    """
    x = np.asarray(u, float)
    x = x[:, None] if x.ndim == 1 else x
    n_pre = settle_samples(model) if n_pre is None else int(n_pre)
    pre = np.vstack([np.repeat(x[:1], n_pre, axis=0), x])
    return model.predict(u=pre)[n_pre:]


# -- the model -----------------------------------------------------------------------------------


class ExtendedModel:
    """Nominal model + sum of terms x coef: the simulation-mode extension of one named cause.

    ``inputs`` are the nominal model's inputs followed by the extra ``columns`` (a load, another
    channel) the terms use; ``predict(u=...)`` takes them in that order, like any model.
    """

    kind = "extended"

    def __init__(self, nominal, cause: str, terms: list, coef, columns=(), note: str = "", preroll: int = 0):
        self.nominal = nominal
        self.cause = cause
        self.terms = list(terms)
        self.coef = np.asarray(coef, float)
        self.columns = tuple(columns)
        self.note = note
        self.preroll = int(preroll)

    @property
    def inputs(self):
        return tuple(self.nominal.inputs) + self.columns

    @property
    def output(self):
        return self.nominal.output

    @property
    def ts(self):
        return self.nominal.ts

    def predict(self, *, u) -> np.ndarray:
        """Simulation (N,) for u (N, len(inputs)) in the data's units; no measured output used."""
        x = np.asarray(u, float)
        x = x[:, None] if x.ndim == 1 else x
        if x.shape[1] != len(self.inputs):
            raise InputError(f"expected {len(self.inputs)} input columns ({', '.join(self.inputs)}), got {x.shape[1]}")
        n_nom = len(self.nominal.inputs)
        yhat = predict_settled(self.nominal, x[:, :n_nom], self.preroll or None)
        return yhat + design(self.terms, x, yhat, self.ts) @ self.coef

    def to_structure(self):
        raise ModelError(f"the {self.cause} extension cannot run in the on-device estimator: {self.note}")

    def to_dict(self) -> dict:
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "cause": self.cause,
            "nominal": self.nominal.to_dict(),
            "columns": list(self.columns),
            "terms": self.terms,
            "coef": [float(c) for c in self.coef],
            "preroll": self.preroll,
            "note": self.note,
        }

    @classmethod
    def from_dict(cls, d: dict) -> ExtendedModel:
        try:
            nominal = Model.from_dict(d["nominal"])
            m = cls(
                nominal, d["cause"], d["terms"], d["coef"], d.get("columns", ()), d.get("note", ""), d.get("preroll", 0)
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"malformed extended model ({exc})") from exc
        if len(m.coef) != sum(
            term_columns(t, np.zeros((2, len(m.inputs))), np.zeros(2), 1.0).shape[1] for t in m.terms
        ):
            raise ModelError("extended model: coefficient count does not match its terms")
        return m

    def save(self, path) -> Path:
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=1, allow_nan=False))
        return path

    def __repr__(self) -> str:
        return f"ExtendedModel({self.cause}, {len(self.terms)} terms on {self.nominal!r})"
