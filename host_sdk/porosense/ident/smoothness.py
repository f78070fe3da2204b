"""The smoothness weight of the selected model's piecewise-linear maps, chosen on validation data."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from porosense.ident.candidates import SearchResult
from porosense.ident.models import Model, as_recordings
from porosense.ident.tasks import score_records


@dataclass
class SmoothnessChoice:
    """Weights of the breakpoint smoothness penalty tried on the selected model.

    Attributes
    ----------
    weight : float
        The weight kept, dimensionless (0: no penalty).
    fits : dict of float to float
        Weight to the validation fit it gave, %.
    model : Model
        The model refined with the weight kept.
    """

    weight: float
    fits: dict
    model: Model | None = field(repr=False, default=None)

    def __str__(self) -> str:
        tried = ", ".join(f"{w:g}: {f:.2f} %" for w, f in self.fits.items())
        return f"smoothness weight {self.weight:g} kept (validation fit per weight: {tried})"


def choose_smoothness(
    result: SearchResult,
    *,
    u,
    y,
    ts: float | None = None,
    validation,
    validation_skip=0,
    weights=(1e-4, 1e-3, 1e-2),
    monotone: bool = False,
    inputs=None,
    output: str | None = None,
) -> SmoothnessChoice:
    """The smoothness weight of the selected model's maps, chosen on validation data.

    The selected (nonlinear) model is refined with each weight from its own parameters on the
    estimation records; the weight with the best validation fit is kept, the unpenalised model
    being the weight-0 entry. A linear model has no breakpoints: returned as is.

    Parameters
    ----------
    result : SearchResult
        The search whose selected model is refined.
    u, y : list of ndarray
        Estimation inputs (N, n_inputs) and outputs (N,) per recording, data units.
    ts : float or None
        Accepted for older callers; the model's own period is used, s.
    validation : tuple or None
        (inputs, outputs) of the validation recordings; None: no choice (weight 0).
    validation_skip : int or sequence of int
        Leading samples of each validation recording not scored.
    weights : sequence of float
        Weights tried, dimensionless (see ``refine._penalty_rows``).
    monotone : bool
        Keep the maps monotone while refining.
    inputs, output : optional
        Accepted for older callers; the model's own names are used.

    Returns
    -------
    SmoothnessChoice
        The weight kept, the fit of each weight and the model.
    """
    best = result.best
    base = result.model
    if best.structure == "linear" or validation is None:
        return SmoothnessChoice(0.0, {}, base)
    vu, vy = as_recordings(*validation)
    skips = skips_of(validation_skip, len(vy))
    fits = {0.0: best.validation_fit}
    chosen, top = base, best.validation_fit
    for w in weights:
        trial = copy.copy(base)
        trial.smoothness, trial.monotone = float(w), bool(monotone)
        m = trial.refine(u=u, y=y)
        f = float(np.mean(score_records(m, vu, vy, skips)["fit"]))
        fits[float(w)] = f
        if f > top:
            chosen, top = m, f
    return SmoothnessChoice(chosen.smoothness, fits, chosen)


def skips_of(skip, n: int) -> list:
    """One number of unscored leading samples per recording from one number or a sequence."""
    return [int(k) for k in skip] if isinstance(skip, (list, tuple, np.ndarray)) else [int(skip)] * n
