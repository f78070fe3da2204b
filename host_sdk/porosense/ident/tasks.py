"""The work of an order search that runs on workers: fitting the candidates of one order,
refining a finalist on all the data, and scoring models into candidates.

Every function here is top level (process pools and Dask pickle it by name) and takes the
records as one :class:`SearchData`, which a Dask cluster receives once (workers.Cluster.share).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from porosense.dsp.blas import single_threaded
from porosense.dsp.heap import reuses_freed_memory
from porosense.ident.candidates import Candidate, tie_tolerance
from porosense.ident.models import Model, Scaling, make_model


@dataclass
class SearchData:
    """The records of one search (data units): estimation ``us``/``ys`` scored past ``skip``,
    validation ``val`` = (inputs, outputs, skips) or None, and what the candidates are fitted
    on: ``fit_us``/``fit_ys`` past ``fit_skip`` (the records themselves, or the screening
    subset). ``scaling`` is the estimation records' own, shared by every candidate."""

    us: list
    ys: list
    ts: float
    skip: int
    val: tuple | None
    scaling: Scaling
    fit_us: list
    fit_ys: list
    fit_skip: int
    inputs: tuple | None = None
    output: str = "y"
    input_unit: object = None
    output_unit: str | None = None
    subset_note: str = ""

    @property
    def screening(self) -> bool:
        """Whether candidates are fitted on a subset of the records."""
        return self.fit_us is not self.us

    @property
    def n_validation(self) -> int:
        return int(sum(len(y) - k for y, k in zip(self.val[1], self.val[2]))) if self.val else 0

    def fit_kwargs(self, full: bool = False) -> dict:
        """Keyword arguments of Model.fit on the fitting records (``full``: on all records)."""
        return {
            "u": self.us if full else self.fit_us,
            "y": self.ys if full else self.fit_ys,
            "ts": self.ts,
            "inputs": self.inputs,
            "output": self.output,
            "input_unit": self.input_unit,
            "output_unit": self.output_unit,
            "scaling": self.scaling,
        }


def score_records(model: Model, us, ys, skips) -> dict:
    """Fit % and RMS % per recording, each with its own number of unscored leading samples.

    A model with process noise is scored by its expected output: the recordings it is
    selected on carry the noise it models (Model.predict)."""
    out: dict[str, list[float]] = {"fit": [], "rms": []}
    for u, y, k in zip(us, ys, skips):
        r = model.score(u=[u], y=[y], skip=int(k), expected=True)
        out["fit"] += r["fit"]
        out["rms"] += r["rms"]
    return out


def score(structure: str, n_poles: int, n_zeros: int, model: Model, data: SearchData, seconds=0.0, cpu=0.0):
    """``model`` as a :class:`Candidate`: fits and RMS on every estimation and validation record.

    AIC and BIC are those of the model's own fit (on the records it was fitted on)."""
    est = model.score(u=data.us, y=data.ys, skip=data.skip, expected=True)
    vs = score_records(model, *data.val) if data.val else {"fit": [], "rms": []}
    return Candidate(
        structure,
        n_poles,
        n_zeros,
        est["fit"],
        vs["fit"],
        est["rms"],
        vs["rms"],
        model.aic,
        model.bic,
        model.n_params,
        seconds,
        True,
        model,
        cpu,
        data.n_validation,
    )


def best_member(structure, n_poles, n_zeros, model: Model, data: SearchData, criterion: str, others=()) -> Candidate:
    """The model or one of its alternative members (or one of the candidates ``others`` of the
    same structure and order), whichever scores best by ``criterion``."""
    own = [] if model.info.get("process_noise", {}).get("method", "").endswith("rejected") else [model]
    # A noise model the period differences refute is only its output-error fit with a vanishing
    # noise: its members (that fit among them) stand instead.
    members = [score(structure, n_poles, n_zeros, m, data) for m in own + model.alternative_models()]
    best = max(members + list(others), key=lambda c: c.score(criterion))
    measured = bool(own) and model.info.get("process_noise", {}).get("method") == "repeated periods"
    if (
        measured
        and members[0] is not best
        and members[0].score(criterion) >= best.score(criterion) - tie_tolerance(best, criterion)
    ):
        # The noise level was measured and the noise-aware model (what process_noise asks for)
        # validates within the noise of its output-error member: the validation data carry
        # the same process noise and cannot tell the noise-free map from the smoothed one.
        best = members[0]
    best.model.alternatives = []
    return best


@reuses_freed_memory
@single_threaded
def fit_order(structures, n_poles, n_zeros, kwargs, data: SearchData, criterion: str, linear=None) -> list:
    """Worker: the candidates of ``structures`` at one order, fitted on ``data``'s fitting records.

    Every nonlinear structure starts from the linear model of the order (``linear`` when it was
    fitted already, else fitted first), the WH model also from the Wiener and Hammerstein
    models. The WH candidate is the member with the best selection score among the jointly
    refined builds and their starting points (WH models with identity blocks equal to the
    linear, Wiener and Hammerstein models), so it scores at least as well as each of them.
    Times of parts that are not candidates themselves are added to the WH candidate's.
    """
    out, extra = [], [0.0, 0.0]
    parts = {"linear": linear} if linear is not None else {}
    fit_args = data.fit_kwargs()
    needed = ["linear"] + [s for s in ("wiener", "hammerstein") if s in structures or "wh" in structures]
    for s in needed:
        if s in parts:
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        start = {"linear": parts["linear"]} if s != "linear" else {}
        parts[s] = make_model(s, n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args, **start)
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        if s in structures:
            t1, c1 = time.perf_counter(), time.process_time()
            out.append(score(s, n_poles, n_zeros, parts[s], data, dt, dc))
            out[-1].seconds += time.perf_counter() - t1
            out[-1].cpu_seconds += time.process_time() - c1
        else:
            extra[0] += dt
            extra[1] += dc
    if "wh" in structures:
        t0, c0 = time.perf_counter(), time.process_time()
        wh = make_model("wh", n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args, **parts)
        # The refined model and the WH members it was refined from, scored by the selection rule:
        # the WH candidate of this order is never below the linear, Wiener and Hammerstein ones.
        best = best_member("wh", n_poles, n_zeros, wh, data, criterion)
        best.seconds = time.perf_counter() - t0 + extra[0]
        best.cpu_seconds = time.process_time() - c0 + extra[1]
        out.append(best)
    if data.screening:
        for c in out:
            c.screened = True
    return out


@reuses_freed_memory
@single_threaded
def refine_candidate(candidate: Candidate, data: SearchData, max_nfev: int) -> tuple[Candidate, bool]:
    """Worker: ``candidate``'s model refined on all the estimation records for at most
    ``max_nfev`` evaluations, rescored; (candidate, converged)."""
    t0, c0 = time.perf_counter(), time.process_time()
    assert candidate.model is not None  # every scored candidate holds its model (score)
    model = candidate.model.refine(u=data.us, y=data.ys, skip=data.skip, max_nfev=max_nfev)
    out = score(candidate.structure, candidate.n_poles, candidate.n_zeros, model, data)
    out.seconds = candidate.seconds + time.perf_counter() - t0
    out.cpu_seconds = time.process_time() - c0  # this task's own: the cost model counts it once
    out.feasible, out.refuted = candidate.feasible, candidate.refuted
    return out, bool(model.converged)


def cpu_of(result) -> float:
    """CPU seconds a task result reports (a candidate list, or a (candidate, converged) pair)."""
    if isinstance(result, tuple):
        return float(result[0].cpu_seconds)
    return float(sum(c.cpu_seconds for c in result if np.isfinite(c.cpu_seconds)))
