"""The candidates of an order search, their scores and the selection rule.

A :class:`Candidate` is one estimated model of the grid with its fits on the estimation and
validation recordings; a :class:`SearchResult` holds them all and selects by its criterion
(the paper's mean fit, the validation fit with its one-standard-error tie rule, AIC or BIC).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from porosense.errors import InputError, ModelError
from porosense.ident.metrics import relative_standard_error
from porosense.ident.models import Model
from porosense.ident.options import CRITERIA, STRUCTURES


@dataclass
class Candidate:
    """One estimated model of the order grid and its scores.

    Fits are NRMSE fits in %, RMS errors in % of max |y|, one per recording.

    Attributes
    ----------
    structure : str
        ``"linear"``, ``"hammerstein"``, ``"wiener"`` or ``"wh"``.
    n_poles, n_zeros : int
        Its order.
    fit_estimation, fit_validation : list of float
        Fit per estimation and per validation recording, %.
    rms_estimation, rms_validation : list of float
        RMS error per recording, % of max |y|.
    aic, bic : float
        Information criteria on the estimation data.
    n_params : int
        Estimated parameters.
    seconds : float
        Wall time of its estimation, s.
    feasible : bool
        Whether it meets the device constraint (size, limits).
    model : Model or None
        The fitted model.
    cpu_seconds : float
        CPU time of its estimation, s.
    n_validation : int
        Validation samples scored.
    refuted : bool
        Its order's linear model is refuted by the nonparametric best linear approximation.
    screened : bool
        Fitted on the screening subset only, not refined on all the data.
    """

    structure: str
    n_poles: int
    n_zeros: int
    fit_estimation: list
    fit_validation: list
    rms_estimation: list
    rms_validation: list
    aic: float
    bic: float
    n_params: int
    seconds: float
    feasible: bool = True
    model: Model | None = field(default=None, repr=False)
    cpu_seconds: float = float("nan")
    n_validation: int = 0
    refuted: bool = False  # its order's linear model is refuted by the nonparametric BLA (bla_test)
    screened: bool = False  # fitted on the screening subset only (screening.py), not refined on all data

    @property
    def validation_fit(self) -> float:
        """Mean fit over the validation recordings (-inf without validation data)."""
        vals = [v for v in self.fit_validation if np.isfinite(v)]
        return float(np.mean(vals)) if vals else float("-inf")

    @property
    def estimation_fit(self) -> float:
        vals = [v for v in self.fit_estimation if np.isfinite(v)]
        return float(np.mean(vals)) if vals else float("-inf")

    def score(self, criterion: str) -> float:
        """Selection score, higher is better.

        Parameters
        ----------
        criterion : str
            ``"paper"``: mean fit over estimation and validation; ``"fit"``: over validation (or
            estimation without validation data); ``"aic"``, ``"bic"``: minus the criterion on the
            estimation data.

        Returns
        -------
        float
            Fit %, or minus AIC / BIC (-inf when not finite).

        Raises
        ------
        InputError
            An unknown criterion.
        """
        if criterion == "paper":
            return self.mean_fit
        if criterion == "fit":
            return self.validation_fit if self.fit_validation else self.estimation_fit
        if criterion in ("aic", "bic"):
            v = self.aic if criterion == "aic" else self.bic
            return -v if np.isfinite(v) else float("-inf")
        raise InputError(f"unknown criterion {criterion!r}; choose from {', '.join(CRITERIA)}")

    @property
    def mean_fit(self) -> float:
        """Mean fit over all estimation and validation recordings (the selection score)."""
        vals = [v for v in self.fit_estimation + self.fit_validation if np.isfinite(v)]
        return float(np.mean(vals)) if vals else float("-inf")

    @property
    def mean_rms(self) -> float:
        vals = [v for v in self.rms_estimation + self.rms_validation if np.isfinite(v)]
        return float(np.mean(vals)) if vals else float("nan")

    def to_dict(self) -> dict:
        """The candidate's figures as a plain dict (without the model).

        Returns
        -------
        dict
            Structure, orders, fits and RMS (%), AIC, BIC, parameters, times (s), flags and build.
        """
        return {
            "structure": self.structure,
            "n_poles": self.n_poles,
            "n_zeros": self.n_zeros,
            "mean_fit": self.mean_fit,
            "mean_rms": self.mean_rms,
            "fit_estimation": self.fit_estimation,
            "fit_validation": self.fit_validation,
            "rms_estimation": self.rms_estimation,
            "rms_validation": self.rms_validation,
            "aic": self.aic,
            "bic": self.bic,
            "n_params": self.n_params,
            "seconds": self.seconds,
            "cpu_seconds": self.cpu_seconds,
            "feasible": self.feasible,
            "refuted": self.refuted,
            "screened": self.screened,
            "build": (self.model.info.get("build") if self.model is not None else None),
        }


@dataclass
class SearchResult:
    """All candidates of a search and the selection.

    With a fit criterion, candidates whose score is within the noise of the best (one standard
    error of the fit, (100 - fit) / sqrt(2 N) points for N scored samples, at least ``tie_tol``)
    are tied and the one with the fewest parameters is taken. With validation data, a nonlinear
    model that validates worse than the best linear model is never selected over it.

    Attributes
    ----------
    candidates : list of Candidate
        Every model estimated.
    seconds : float
        Wall time of the search, s.
    tie_tol : float
        Smallest tie tolerance, fit points.
    criterion : str
        ``"paper"`` (mean fit over estimation and validation recordings, the paper's rule),
        ``"fit"`` (mean fit on the validation recordings), ``"aic"`` or ``"bic"``.
    holdout : str
        How the validation data were made, in words.
    cpu_seconds : float
        CPU time of every process that worked on the search, s.
    """

    candidates: list
    seconds: float
    tie_tol: float = 0.01
    criterion: str = "paper"
    holdout: str = ""
    cpu_seconds: float = float("nan")  # CPU time of every process that worked on the search

    @property
    def feasible(self) -> list:
        return [c for c in self.candidates if c.feasible]

    def tolerance(self, top: Candidate) -> float:
        """Fit points within which candidates are tied with ``top`` (:func:`tie_tolerance`).

        Parameters
        ----------
        top : Candidate
            The best-scoring candidate.

        Returns
        -------
        float
            Fit points.
        """
        return tie_tolerance(top, self.criterion, self.tie_tol)

    def eligible(self) -> list:
        """The candidates the selection may take: feasible, at orders the BLA does not refute, refined
        on all the data (each condition dropped when no candidate meets it).

        Returns
        -------
        list of Candidate
            In search order.
        """
        pool = self.feasible or self.candidates
        pool = [c for c in pool if not c.refuted] or pool
        return [c for c in pool if not c.screened] or pool

    def _select(self):
        pool = self.eligible()
        key = lambda c: c.score(self.criterion)
        top = max(pool, key=key)
        tol = self.tolerance(top)
        near = [c for c in pool if key(c) >= key(top) - tol]
        best = min(near, key=lambda c: (c.n_params, -key(c)))
        note = ""
        linears = [c for c in pool if c.structure == "linear"]
        if best.structure != "linear" and linears and best.fit_validation:
            lin = max(linears, key=lambda c: c.validation_fit)
            if best.validation_fit < lin.validation_fit:
                note = (
                    f"{best.structure} {best.n_poles}p{best.n_zeros}z validates worse than linear "
                    f"({best.validation_fit:.2f} % < {lin.validation_fit:.2f} %): linear kept"
                )
                best = lin
        return best, top, tol, near, note

    @property
    def best(self) -> Candidate:
        """The selected candidate (see the class docstring for the rule)."""
        return self._select()[0]

    @property
    def rule(self) -> str:
        """One line: how the selected candidate was chosen."""
        best, top, tol, near, note = self._select()
        what = {
            "paper": "mean fit over estimation and validation recordings",
            "fit": "mean fit on the validation data"
            if top.fit_validation
            else "mean fit on the estimation data (no validation data)",
            "aic": "lowest AIC on the estimation data",
            "bic": "lowest BIC on the estimation data",
        }[self.criterion]
        text = f"rule: {what}"
        if self.criterion in ("fit", "paper"):
            text += (
                f"; {len(near)} candidate(s) within {tol:.3g} points of the best "
                f"({top.score(self.criterion):.2f} %), the fewest parameters taken"
            )
        if self.holdout:
            text += f"; validation: {self.holdout}"
        if note:
            text += f"; {note}"
        return text

    @property
    def model(self) -> Model:
        """The selected model."""
        model = self.best.model
        if model is None:
            raise ModelError("the selected candidate holds no model")
        return model

    def best_per_structure(self, criterion: str = "paper") -> dict:
        """The best candidate of each structure among those the selection may take.

        Parameters
        ----------
        criterion : str
            Selection criterion (default the paper's mean fit).

        Returns
        -------
        dict of str to Candidate
            Structure name to its best candidate.
        """
        out: dict[str, Candidate] = {}
        for c in self.eligible():
            if c.structure not in out or c.score(criterion) > out[c.structure].score(criterion):
                out[c.structure] = c
        return out

    def table(self) -> list[dict]:
        """One plain dict per candidate, best mean fit first (no pandas needed).

        Returns
        -------
        list of dict
            :meth:`Candidate.to_dict` rows.
        """
        rows = [c.to_dict() for c in self.candidates]
        return sorted(rows, key=lambda r: -r["mean_fit"] if np.isfinite(r["mean_fit"]) else np.inf)

    def to_dict(self) -> dict:
        """The search as a plain dict.

        Returns
        -------
        dict
            The selected candidate, time (s), criterion, rule, hold-out, the best per structure and
            every candidate.
        """
        best = self.best
        return {
            "best": best.to_dict(),
            "seconds": self.seconds,
            "criterion": self.criterion,
            "rule": self.rule,
            "holdout": self.holdout,
            "best_per_structure": {k: v.to_dict() for k, v in self.best_per_structure().items()},
            "candidates": self.table(),
        }

    def __str__(self) -> str:
        lines = [
            f"{'structure':<12}{'poles':>6}{'zeros':>6}{'mean fit %':>12}{'est fit %':>11}{'val fit %':>11}"
            f"{'mean RMS %':>12}{'AIC':>12}{'BIC':>12}"
        ]
        for c in sorted(self.best_per_structure(self.criterion).values(), key=lambda c: -c.score(self.criterion)):
            val = f"{c.validation_fit:>11.2f}" if c.fit_validation else f"{'-':>11}"
            lines.append(
                f"{c.structure:<12}{c.n_poles:>6}{c.n_zeros:>6}{c.mean_fit:>12.2f}{c.estimation_fit:>11.2f}"
                f"{val}{c.mean_rms:>12.2f}{c.aic:>12.4g}{c.bic:>12.4g}"
            )
        b = self.best
        val = f"{b.validation_fit:.2f} %" if b.fit_validation else "-"
        lines.append(
            f"selected: {b.structure} ({b.n_poles} poles, {b.n_zeros} zeros), "
            f"{len(self.candidates)} candidates in {self.seconds:.1f} s"
        )
        lines.append(
            f"selected row: {b.structure:<12}{b.n_poles:>3}p{b.n_zeros:>3}z  estimation fit "
            f"{b.estimation_fit:.2f} %  validation fit {val}  AIC {b.aic:.5g}  BIC {b.bic:.5g}"
            + (f"  [{b.model.info['build']}]" if b.model is not None and b.model.info.get("build") else "")
        )
        lines.append(self.rule)
        return "\n".join(lines)

    def plot(self, ax=None):
        """Mean fit versus number of poles, one line per structure (best over zeros).

        Parameters
        ----------
        ax : matplotlib Axes or None
            Where to draw (None: a new figure).

        Returns
        -------
        matplotlib Axes
            Fit (%) against poles.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        for s in STRUCTURES:
            pts: dict[int, float] = {}
            for c in self.candidates:
                if c.structure == s and c.feasible:
                    pts[c.n_poles] = max(pts.get(c.n_poles, -np.inf), c.mean_fit)
            if pts:
                k = sorted(pts)
                ax.plot(k, [pts[i] for i in k], marker="o", label=s)
        ax.set_xlabel("number of poles")
        ax.set_ylabel("mean fit (%)")
        ax.legend()
        ax.grid(True, alpha=0.3)
        return ax


def tie_tolerance(top: Candidate, criterion: str, tie_tol: float = 0.01) -> float:
    """Score points within which candidates are tied with ``top``.

    Parameters
    ----------
    top : Candidate
        The best-scoring candidate.
    criterion : str
        The selection criterion (``"paper"``, ``"fit"``, ``"aic"``, ``"bic"``).
    tie_tol : float
        Smallest tolerance, fit points.

    Returns
    -------
    float
        One standard error of ``top``'s fit, (100 - fit) / sqrt(2 N) points for N scored samples
        (at least ``tie_tol``); ``tie_tol`` for the paper's rule; 0 for AIC and BIC.
    """
    if criterion not in ("fit", "paper"):
        return 0.0
    n = top.n_validation if top.fit_validation else top.model.info.get("n_samples", 0) if top.model else 0
    if criterion == "paper" or n <= 0:
        return tie_tol
    return max(tie_tol, (100.0 - top.score(criterion)) * relative_standard_error(n))


def feasible(model, constraint, size_fn, max_bytes) -> bool:
    if constraint is None and (size_fn is None or max_bytes is None):
        return True
    structure = model.to_structure()
    if constraint is not None and not constraint(structure):
        return False
    if size_fn is not None and max_bytes is not None and size_fn(structure) > max_bytes:
        return False
    return True


def approx_blob_bytes(structure) -> int:
    """Rough size of a fixed-point model blob: 16-bit coefficients, 32-bit PWL points.

    An estimate for the device constraint; the exact size comes from porosense.quant.

    Parameters
    ----------
    structure : EstimatorStructure
        The model.

    Returns
    -------
    int
        Estimated blob size, bytes.
    """
    size = 16
    for out in structure.outputs:
        size += 8
        for br in out.branches:
            size += 4 + 10 * br.h1.n_sections + (8 * len(br.f.x) if br.f is not None else 0)
        size += 8 * len(out.g.x) if out.g is not None else 0
        size += 10 * out.h2.n_sections if out.h2 is not None else 0
    return size
