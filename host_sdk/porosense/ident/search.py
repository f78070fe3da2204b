"""Order search over structures, with the paper's selection rule.

Every (structure, n_poles, n_zeros) of the grid is estimated on the estimation recordings as
a task on a concurrent.futures Executor (a WH order shares its task with the Wiener and
Hammerstein models of that order, which are its starting points) (a local process pool by default; a Dask client's
``get_executor()`` works unchanged). The model picked is the one with the highest mean NRMSE
fit over all estimation and validation recordings (the paper's rule); AIC and BIC are
reported for each candidate. An optional ``constraint(structure) -> bool`` (or a size
function with a byte budget) removes models that would not fit the device.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field

import numpy as np

from porosense.errors import InputError
from porosense.ident.bla_test import NonparametricBLA
from porosense.ident.metrics import relative_standard_error
from porosense.ident.models import KINDS, NOISE_KINDS, Model, as_recordings, make_model

STRUCTURES = tuple(KINDS)
CRITERIA = ("paper", "fit", "aic", "bic")


@dataclass
class Candidate:
    """One estimated model of the grid and its scores (fits and RMS in %, per recording)."""

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
        """Selection score, higher is better: the mean fit (``paper``: over estimation and
        validation; ``fit``: over validation, or estimation without validation data), or minus
        AIC / BIC (on the estimation data)."""
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
            "build": (self.model.info.get("build") if self.model is not None else None),
        }


@dataclass
class SearchResult:
    """All candidates of a search and the selection.

    ``criterion``: ``paper`` (mean fit over estimation + validation recordings, the paper's
    rule), ``fit`` (mean fit on the validation recordings only), ``aic`` or ``bic``. With a fit
    criterion, candidates whose score is within the noise of the best (one standard error of
    the fit, (100 - fit) / sqrt(2 N) points for N scored samples, at least ``tie_tol``) are tied
    and the one with the fewest parameters is taken. With validation data, a nonlinear model
    that validates worse than the best linear model is never selected over it.
    """

    candidates: list
    seconds: float
    tie_tol: float = 0.01
    criterion: str = "paper"
    holdout: str = ""

    @property
    def feasible(self) -> list:
        return [c for c in self.candidates if c.feasible]

    def tolerance(self, top: Candidate) -> float:
        """Fit points within which candidates are tied (one standard error of ``top``'s fit)."""
        return tie_tolerance(top, self.criterion, self.tie_tol)

    def _select(self):
        pool = self.feasible or self.candidates
        pool = [c for c in pool if not c.refuted] or pool
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
        return self.best.model

    def best_per_structure(self, criterion: str = "paper") -> dict:
        """The best candidate of each structure by ``criterion`` (default the paper's mean fit),
        among the candidates the selection may take (feasible, at orders the BLA does not refute)."""
        out = {}
        pool = self.feasible or self.candidates
        for c in [c for c in pool if not c.refuted] or pool:
            if c.structure not in out or c.score(criterion) > out[c.structure].score(criterion):
                out[c.structure] = c
        return out

    def table(self) -> list[dict]:
        """One plain dict per candidate, best first (no pandas needed)."""
        rows = [c.to_dict() for c in self.candidates]
        return sorted(rows, key=lambda r: -r["mean_fit"] if np.isfinite(r["mean_fit"]) else np.inf)

    def to_dict(self) -> dict:
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
        """Mean fit versus number of poles, one line per structure (best over zeros)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        for s in STRUCTURES:
            pts = {}
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


def order_grid(structures=STRUCTURES, poles=range(1, 11), zeros=None) -> list[tuple[str, int, int]]:
    """(structure, n_poles, n_zeros) for every structure, pole count and zero count < poles.

    ``zeros`` restricts the zero counts (still < poles); default all of 0..n_poles-1.
    """
    grid = []
    for s in structures:
        if s not in KINDS:
            raise InputError(f"unknown structure {s!r}; choose from {', '.join(KINDS)}")
        for p in poles:
            for z in range(p):
                if zeros is None or z in zeros:
                    grid.append((s, int(p), int(z)))
    return grid


def _score_records(model, us, ys, skips) -> dict:
    """Fit % and RMS % per recording, each with its own number of unscored leading samples.

    A model with process noise is scored by its expected output: the recordings it is
    selected on carry the noise it models (Model.predict)."""
    out = {"fit": [], "rms": []}
    for u, y, k in zip(us, ys, skips):
        r = model.score(u=[u], y=[y], skip=int(k), expected=True)
        out["fit"] += r["fit"]
        out["rms"] += r["rms"]
    return out


def _skips(skip, n: int) -> list:
    return list(skip) if isinstance(skip, (list, tuple, np.ndarray)) else [int(skip)] * n


def _score(structure, n_poles, n_zeros, model, kwargs, fit_args, val, seconds, cpu_seconds) -> Candidate:
    est = model.score(u=fit_args["u"], y=fit_args["y"], skip=kwargs["skip"], expected=True)
    vs = _score_records(model, *val) if val else {"fit": [], "rms": []}
    n_val = int(sum(len(y) - k for y, k in zip(val[1], val[2]))) if val else 0
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
        cpu_seconds,
        n_val,
    )


def tie_tolerance(top: Candidate, criterion: str, tie_tol: float = 0.01) -> float:
    """Score points within which candidates are tied with ``top``: one standard error of its
    fit, (100 - fit) / sqrt(2 N) for N scored samples (at least ``tie_tol``); 0 for AIC/BIC."""
    if criterion not in ("fit", "paper"):
        return 0.0
    n = top.n_validation if top.fit_validation else top.model.info.get("n_samples", 0) if top.model else 0
    if criterion == "paper" or n <= 0:
        return tie_tol
    return max(tie_tol, (100.0 - top.score(criterion)) * relative_standard_error(n))


def _best_member(structure, n_poles, n_zeros, model, kwargs, fit_args, val, criterion, others=()) -> Candidate:
    """The model or one of its alternative members (or one of the candidates ``others`` of the
    same structure and order), whichever scores best by ``criterion``."""
    own = [] if model.info.get("process_noise", {}).get("method", "").endswith("rejected") else [model]
    # A noise model the period differences refute is only its output-error fit with a vanishing
    # noise: its members (that fit among them) stand instead.
    members = [
        _score(structure, n_poles, n_zeros, m, kwargs, fit_args, val, 0.0, 0.0)
        for m in own + model.alternative_models()
    ]
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


def _fit_candidate(structure, n_poles, n_zeros, kwargs, fit_args, val):
    """Worker: estimate one model and score it (top level so process pools can pickle it)."""
    t0, c0 = time.perf_counter(), time.process_time()
    model = make_model(structure, n_poles=n_poles, n_zeros=n_zeros, **kwargs)
    model.fit(**fit_args)
    return _score(
        structure, n_poles, n_zeros, model, kwargs, fit_args, val, time.perf_counter() - t0, time.process_time() - c0
    )


def _fit_order_group(structures, n_poles, n_zeros, kwargs, fit_args, val, criterion="paper") -> list:
    """Worker: every structure of one order, each nonlinear one started from the linear model
    of the order (fitted first), the WH model also from the Wiener and Hammerstein models.

    Returns the candidates of ``structures``. The WH candidate is the member with the best
    selection score among the jointly refined builds and their starting points (WH models
    with identity blocks equal to the linear, Wiener and Hammerstein models), so it scores at
    least as well as each of them. Times of parts that are not candidates themselves are
    added to the WH candidate's.
    """
    out, extra = [], [0.0, 0.0]
    parts = {}
    needed = ["linear"] + [s for s in ("wiener", "hammerstein") if s in structures or "wh" in structures]
    for s in needed:
        t0, c0 = time.perf_counter(), time.process_time()
        start = {"linear": parts["linear"]} if s != "linear" else {}
        parts[s] = make_model(s, n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args, **start)
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        if s in structures:
            out.append(_score(s, n_poles, n_zeros, parts[s], kwargs, fit_args, val, dt, dc))
        else:
            extra[0] += dt
            extra[1] += dc
    if "wh" in structures:
        t0, c0 = time.perf_counter(), time.process_time()
        wh = make_model("wh", n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args, **parts)
        # The refined model and the WH members it was refined from, scored by the selection rule:
        # the WH candidate of this order is never below the linear, Wiener and Hammerstein ones.
        best = _best_member("wh", n_poles, n_zeros, wh, kwargs, fit_args, val, criterion)
        best.seconds = time.perf_counter() - t0 + extra[0]
        best.cpu_seconds = time.process_time() - c0 + extra[1]
        out.append(best)
    return out


def _tasks(grid) -> list[tuple[tuple[str, ...], int, int]]:
    """Group the grid into tasks: every structure of an order that has a nonlinear one runs in
    one task (they start from the linear model of the order); a lone linear candidate alone."""
    groups: dict = {}
    tasks = []
    for s, p, z in grid:
        if (p, z) not in groups:
            groups[(p, z)] = []
            tasks.append(((p, z), groups[(p, z)]))
        groups[(p, z)].append(s)
    return [(tuple(ss), p, z) for (p, z), ss in tasks]


def _run_task(structures, n_poles, n_zeros, kwargs, fit_args, val, criterion="paper") -> list:
    if structures == ("linear",):
        return [_fit_candidate("linear", n_poles, n_zeros, kwargs, fit_args, val)]
    return _fit_order_group(structures, n_poles, n_zeros, kwargs, fit_args, val, criterion)


def search(
    *,
    u,
    y,
    ts: float,
    validation=None,
    structures=STRUCTURES,
    poles=range(1, 11),
    zeros=None,
    n_breakpoints: int = 10,
    delay: int = 0,
    starts: int = 2,
    max_nfev: int = 100,
    skip: int = 0,
    inputs=None,
    output: str = "y",
    executor: Executor | None = None,
    progress: bool = True,
    constraint=None,
    size_fn=None,
    max_bytes: int | None = None,
    grid=None,
    tie_tol: float = 0.01,
    validation_skip=0,
    criterion: str = "paper",
    holdout: str = "",
    staged: bool = False,
    staged_orders: int = 2,
    smoothness: float = 0.0,
    monotone: bool = False,
    process_noise: bool = False,
    input_unit=None,
    output_unit: str | None = None,
) -> SearchResult:
    """Estimate the whole grid and select by ``criterion`` (see :class:`SearchResult`).

    u, y: estimation recordings (lists of (N, n_in) and (N,)); validation: (u_list, y_list) or
    None; ts in s. ``constraint(structure) -> bool`` or ``size_fn(structure) -> bytes`` with
    ``max_bytes`` mark candidates infeasible (they are reported, never selected unless no
    candidate is feasible). ``executor``: any concurrent.futures Executor; default a process
    pool over the machine's cores (a single candidate runs in this process). ``skip`` and
    ``validation_skip``: leading samples of each recording simulated but not scored (for the
    validation recordings one number or one per recording). ``grid``: an explicit list of
    (structure, n_poles, n_zeros) instead of structures/poles/zeros. ``criterion``: paper
    (default, the paper's mean fit over all recordings), fit (validation fit), aic or bic.
    ``holdout``: how the validation data was made, reported with the rule.

    ``process_noise``: after the output-error search, the best Wiener and the best WH candidate
    by ``criterion`` are refitted with a Gaussian noise at g's input (:meth:`Model.predict`,
    started from the same models of their order) and scored by their expected output; each
    becomes the better of its process-noise and output-error fits (:func:`_best_member`). A
    process-noise fit costs many output-error fits, so only these finalists get one. When the
    estimation records are at least 4 realisations of one periodic input, the orders come from
    their nonparametric BLA instead (:func:`_bla_ordered_search`): validation data carrying the
    same noise cannot rank them.
    ``input_unit`` / ``output_unit``: stored in every model (:meth:`Model.fit`).

    ``smoothness`` / ``monotone``: regularisation of the piecewise-linear maps of every
    nonlinear candidate (:func:`choose_smoothness` picks the weight on validation data).

    ``staged``: first every linear order of the grid, then the nonlinear structures only at the
    ``staged_orders`` best linear orders by ``criterion`` (and the order the tie rule picks):
    a nonlinear model starts from the linear model of its order, so orders whose linear model
    ranks low are not worth refining (the fast default of ``porosense identify`` on long records).
    """
    if criterion not in CRITERIA:
        raise InputError(f"unknown criterion {criterion!r}; choose from {', '.join(CRITERIA)}")
    if process_noise:
        fit_args, val = _fit_args_and_validation(
            u, y, ts, validation, validation_skip, inputs, output, input_unit, output_unit
        )
        args = dict(
            u=u,
            y=y,
            ts=ts,
            validation=validation,
            n_breakpoints=n_breakpoints,
            delay=delay,
            starts=starts,
            max_nfev=max_nfev,
            skip=skip,
            inputs=inputs,
            output=output,
            progress=progress,
            constraint=constraint,
            size_fn=size_fn,
            max_bytes=max_bytes,
            tie_tol=tie_tol,
            validation_skip=validation_skip,
            criterion=criterion,
            holdout=holdout,
            smoothness=smoothness,
            monotone=monotone,
            input_unit=input_unit,
            output_unit=output_unit,
        )
        full = list(grid) if grid is not None else order_grid(structures, poles, zeros)
        bla = NonparametricBLA.from_records(fit_args["u"], fit_args["y"], skip)
        oe = _bla_ordered_search(bla, full, staged, executor, args) if bla is not None else None
        if oe is None:
            oe = search(grid=full, executor=executor, staged=staged, staged_orders=staged_orders, **args)
        return _with_process_noise(
            oe,
            fit_args,
            val,
            _model_options(n_breakpoints, delay, starts, max_nfev, skip, smoothness, monotone),
            constraint,
            size_fn,
            max_bytes,
        )
    if staged:
        args = dict(
            u=u,
            y=y,
            ts=ts,
            validation=validation,
            n_breakpoints=n_breakpoints,
            delay=delay,
            starts=starts,
            max_nfev=max_nfev,
            skip=skip,
            inputs=inputs,
            output=output,
            progress=progress,
            constraint=constraint,
            size_fn=size_fn,
            max_bytes=max_bytes,
            tie_tol=tie_tol,
            validation_skip=validation_skip,
            criterion=criterion,
            holdout=holdout,
            smoothness=smoothness,
            monotone=monotone,
            input_unit=input_unit,
            output_unit=output_unit,
        )
        return _staged_search(
            list(grid) if grid is not None else order_grid(structures, poles, zeros), executor, staged_orders, args
        )
    fit_args, val = _fit_args_and_validation(
        u, y, ts, validation, validation_skip, inputs, output, input_unit, output_unit
    )
    grid = list(grid) if grid is not None else order_grid(structures, poles, zeros)
    if not grid:
        raise InputError("empty order grid")
    rank = {g: i for i, g in enumerate(grid)}
    kwargs = _model_options(n_breakpoints, delay, starts, max_nfev, skip, smoothness, monotone)
    # Most expensive first so that the pool stays busy to the end.
    weight = {"wh": 2, "hammerstein": 2, "wiener": 2, "linear": 1}
    tasks = _tasks(grid)
    tasks.sort(key=lambda t: -(sum(weight[s] for s in t[0]) + (2 if "wh" in t[0] else 0)) * (t[1] + t[2] + 1))
    if executor is None and len(tasks) == 1:
        t0 = time.perf_counter()
        candidates = _run_task(*tasks[0], kwargs, fit_args, val, criterion)
        for c in candidates:
            c.feasible = _feasible(c.model, constraint, size_fn, max_bytes)
        candidates.sort(key=lambda c: rank[(c.structure, c.n_poles, c.n_zeros)])
        return SearchResult(candidates, time.perf_counter() - t0, tie_tol, criterion, holdout)
    own = executor is None
    if own:
        executor = ProcessPoolExecutor(max_workers=min(os.cpu_count() or 1, len(tasks)))
    t0 = time.perf_counter()
    candidates = []
    try:
        futures = [executor.submit(_run_task, ss, p, z, kwargs, fit_args, val, criterion) for ss, p, z in tasks]
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(grid), desc="order search", unit="model", leave=False)
        for fut in as_completed(futures):
            done = fut.result()
            candidates.extend(done)
            if bar is not None:
                bar.update(len(done))
        if bar is not None:
            bar.close()
    finally:
        if own:
            executor.shutdown()
    for c in candidates:
        c.feasible = _feasible(c.model, constraint, size_fn, max_bytes)
    candidates.sort(key=lambda c: rank[(c.structure, c.n_poles, c.n_zeros)])
    return SearchResult(candidates, time.perf_counter() - t0, tie_tol, criterion, holdout)


def _fit_args_and_validation(u, y, ts, validation, validation_skip, inputs, output, input_unit, output_unit):
    """(keyword arguments of Model.fit, (validation inputs, outputs, skips) or None), checked."""
    us, ys = as_recordings(u, y)
    val = None
    if validation is not None:
        vu, vy = as_recordings(*validation)
        vskips = _skips(validation_skip, len(vy))
        if len(vskips) != len(vy) or any(len(v) - k < 2 for v, k in zip(vy, vskips)):
            raise InputError("every validation recording needs at least 2 scored samples after its skip")
        val = (vu, vy, vskips)
    fit_args = {
        "u": us,
        "y": ys,
        "ts": ts,
        "inputs": inputs,
        "output": output,
        "input_unit": input_unit,
        "output_unit": output_unit,
    }
    return fit_args, val


def _model_options(n_breakpoints, delay, starts, max_nfev, skip, smoothness, monotone) -> dict:
    """The make_model options every candidate of a search shares (the penalties only when set)."""
    kwargs = {"n_breakpoints": n_breakpoints, "delay": delay, "starts": starts, "max_nfev": max_nfev, "skip": skip}
    if smoothness or monotone:
        kwargs.update(smoothness=smoothness, monotone=monotone)
    return kwargs


def _with_process_noise(result: SearchResult, fit_args, val, kwargs, constraint, size_fn, max_bytes) -> SearchResult:
    """``result`` with its best Wiener and best WH candidate (by its criterion, feasible first)
    refitted with a process noise at g's input, each replaced by the better of that fit and the
    output-error fits by :func:`_best_member`. The refit starts from the linear, Wiener and
    Hammerstein models of the same order when the search estimated them, as the candidate did.

    Runs in this process, so the WH's builds are refined on a pool of the machine's cores
    (:func:`porosense.ident.estimate._map_builds`)."""
    t0 = time.perf_counter()
    candidates = list(result.candidates)
    refitted = []
    for structure in NOISE_KINDS:
        own = [c for c in candidates if c.structure == structure and c.model is not None]
        if not own:
            continue
        pool = [c for c in own if c.feasible] or own
        pool = [c for c in pool if not c.refuted] or pool
        top = max(pool, key=lambda c: c.score(result.criterion))
        order = (top.n_poles, top.n_zeros)
        parts = {
            c.structure: c.model
            for c in candidates
            if (c.n_poles, c.n_zeros) == order
            and c.structure in ("linear", "wiener", "hammerstein")
            and c.model is not None
            and (structure == "wh" or c.structure == "linear")
        }
        t1, c1 = time.perf_counter(), time.process_time()
        model = make_model(structure, n_poles=top.n_poles, n_zeros=top.n_zeros, process_noise=True, **kwargs)
        model.fit(**fit_args, **parts)
        best = _best_member(
            structure, top.n_poles, top.n_zeros, model, kwargs, fit_args, val, result.criterion, others=[top]
        )
        if best is not top:
            best.seconds = top.seconds + time.perf_counter() - t1
            best.cpu_seconds = top.cpu_seconds + time.process_time() - c1
            best.feasible = _feasible(best.model, constraint, size_fn, max_bytes)
            best.refuted = top.refuted
            candidates[candidates.index(top)] = best
        method = model.info.get("process_noise", {}).get("method", "")
        kept = (
            "process noise rejected by the period differences, output error kept"
            if method.endswith("rejected")
            else "process noise undetermined by the records, output error kept"
            if method.endswith("undetermined")
            else "process noise"
            if best.model.spec.g_noise
            else "output error kept"
        )
        refitted.append(f"{structure} {top.n_poles}p{top.n_zeros}z ({kept})")
    note = (
        "process noise fitted for " + ", ".join(refitted) if refitted else "no Wiener or WH candidate for process noise"
    )
    return SearchResult(
        candidates,
        result.seconds + time.perf_counter() - t0,
        result.tie_tol,
        result.criterion,
        result.holdout + ("; " if result.holdout else "") + note,
    )


# One-sided level at which the nonparametric BLA refutes a linear order (bla_test).
BLA_ALPHA = 0.01


def _bla_ordered_search(bla: NonparametricBLA, grid, staged: bool, executor, args) -> SearchResult | None:
    """The search with orders ranked by the nonparametric BLA instead of validation data.

    The linear orders of the grid are fitted and tested against the BLA (bla_test) in order of
    their number of parameters; the BLA order is the one with the fewest parameters among those
    it does not refute at BLA_ALPHA (the lowest misfit among equals). Candidates at refuted
    orders are kept in the table but never selected (SearchResult). ``staged``: the linear
    orders stop at the first parameter count with an order the BLA does not refute, and the
    nonlinear structures are fitted at the BLA order only. None when the BLA refutes every
    linear order (the caller searches as without it)."""
    t0 = time.perf_counter()
    own = executor is None
    linear_grid = sorted({("linear", p, z) for _, p, z in grid}, key=lambda g: (g[1], g[2]))
    if own and len(linear_grid) > 1:
        executor = ProcessPoolExecutor(max_workers=os.cpu_count() or 1)
    us = as_recordings(args["u"], args["y"])[0]
    limit = bla.threshold(BLA_ALPHA)
    misfit, linear = {}, []
    try:
        # Orders by their number of parameters, all orders of one count at a time; staged, the
        # search stops at the first count with an order the BLA does not refute.
        for count in sorted({p + z for _, p, z in linear_grid}):
            batch = [g for g in linear_grid if g[1] + g[2] == count]
            linear += search(grid=batch, executor=executor, **args).candidates
            misfit.update({(c.n_poles, c.n_zeros): bla.misfit(c.model, us) for c in linear[-len(batch) :]})
            if staged and any(misfit[(p, z)] <= limit for _, p, z in batch):
                break
        kept = [c for c in linear if misfit[(c.n_poles, c.n_zeros)] <= limit]
        if not kept:
            return None
        best = min(kept, key=lambda c: (c.n_params, misfit[(c.n_poles, c.n_zeros)]))
        order = (best.n_poles, best.n_zeros)
        second_grid = [(s, p, z) for s, p, z in grid if s != "linear" and ((p, z) == order or not staged)]
        candidates = [c for c in linear if ("linear", c.n_poles, c.n_zeros) in grid]
        if second_grid:
            candidates += search(grid=second_grid, executor=executor, **args).candidates
    finally:
        if own and executor is not None:
            executor.shutdown()
    for c in candidates:
        c.refuted = misfit.get((c.n_poles, c.n_zeros), 0.0) > limit
    note = (
        f"order from the {bla.describe()}: {order[0]}p{order[1]}z, the fewest parameters of the "
        f"{len(kept)} of {len(linear)} linear order(s) fitted it does not refute (misfit {misfit[order]:.3f} "
        f"<= {limit:.3f}, {100 * BLA_ALPHA:g} % one-sided); candidates at refuted orders not selected"
    )
    return SearchResult(
        candidates,
        time.perf_counter() - t0,
        args["tie_tol"],
        args["criterion"],
        args["holdout"] + ("; " if args["holdout"] else "") + note,
    )


def _staged_search(grid, executor, n_orders: int, args) -> SearchResult:
    """Linear orders first, then the nonlinear structures at the best linear orders."""
    t0 = time.perf_counter()
    own = executor is None
    linear_grid = [g for g in grid if g[0] == "linear"] or [("linear", p, z) for _, p, z in grid]
    if own and len(linear_grid) > 1:
        executor = ProcessPoolExecutor(max_workers=os.cpu_count() or 1)
    try:
        first = search(grid=sorted(set(linear_grid), key=linear_grid.index), executor=executor, **args)
        ranked = sorted(first.candidates, key=lambda c: -c.score(args["criterion"]))
        orders = [(first.best.n_poles, first.best.n_zeros)]
        for c in ranked:
            if len(orders) >= n_orders + 1:
                break
            if (c.n_poles, c.n_zeros) not in orders:
                orders.append((c.n_poles, c.n_zeros))
        second_grid = [(s, p, z) for s, p, z in grid if s != "linear" and (p, z) in orders]
        candidates = [c for c in first.candidates if ("linear", c.n_poles, c.n_zeros) in grid]
        if second_grid:
            candidates += search(grid=second_grid, executor=executor, **args).candidates
    finally:
        if own and executor is not None:
            executor.shutdown()
    return SearchResult(
        candidates,
        time.perf_counter() - t0,
        args["tie_tol"],
        args["criterion"],
        args["holdout"]
        + ("; " if args["holdout"] else "")
        + f"staged search: nonlinear structures at linear orders {', '.join(f'{p}p{z}z' for p, z in orders)}",
    )


def _feasible(model, constraint, size_fn, max_bytes) -> bool:
    if constraint is None and (size_fn is None or max_bytes is None):
        return True
    structure = model.to_structure()
    if constraint is not None and not constraint(structure):
        return False
    if size_fn is not None and max_bytes is not None and size_fn(structure) > max_bytes:
        return False
    return True


def approx_blob_bytes(structure) -> int:
    """Rough size (bytes) of a fixed-point model blob: 16-bit coefficients, 32-bit PWL points.

    An estimate for the device constraint; the exact size comes from porosense.quant.
    """
    size = 16
    for out in structure.outputs:
        size += 8
        for br in out.branches:
            size += 4 + 10 * br.h1.n_sections + (8 * len(br.f.x) if br.f is not None else 0)
        size += 8 * len(out.g.x) if out.g is not None else 0
        size += 10 * out.h2.n_sections if out.h2 is not None else 0
    return size


@dataclass
class SmoothnessChoice:
    """Weights of the breakpoint smoothness penalty tried on the selected model, with their
    validation fits (%); ``weight`` the one kept (0 = no penalty)."""

    weight: float
    fits: dict
    model: Model = field(repr=False, default=None)

    def __str__(self) -> str:
        tried = ", ".join(f"{w:g}: {f:.2f} %" for w, f in self.fits.items())
        return f"smoothness weight {self.weight:g} kept (validation fit per weight: {tried})"


def choose_smoothness(
    result: SearchResult,
    *,
    u,
    y,
    ts: float,
    validation,
    validation_skip=0,
    weights=(1e-4, 1e-3, 1e-2),
    monotone: bool = False,
    inputs=None,
    output: str = "y",
) -> SmoothnessChoice:
    """Refit the selected (nonlinear) model with each smoothness weight (dimensionless, see
    ``estimate._penalty_rows``) and keep the weight with the best validation fit; the
    unpenalised model is the weight-0 entry. Linear models have no breakpoints: returned as is."""
    best = result.best
    base = best.model
    if best.structure == "linear" or validation is None:
        return SmoothnessChoice(0.0, {}, base)
    vu, vy = as_recordings(*validation)
    skips = _skips(validation_skip, len(vy))
    fits = {0.0: best.validation_fit}
    chosen, top = base, best.validation_fit
    for w in weights:
        m = make_model(
            best.structure,
            n_poles=base.n_poles,
            n_zeros=base.n_zeros,
            n_breakpoints=base.n_breakpoints,
            delay=base.delay,
            starts=base.starts,
            max_nfev=base.max_nfev,
            skip=base.skip,
            smoothness=w,
            monotone=monotone,
            process_noise=base.process_noise,
        )
        m.fit(
            u=u,
            y=y,
            ts=ts,
            inputs=inputs,
            output=output,
            input_unit=list(base.input_units) or None,
            output_unit=base.output_unit,
        )
        f = float(np.mean(_score_records(m, vu, vy, skips)["fit"]))
        fits[float(w)] = f
        if f > top:
            chosen, top = m, f
    return SmoothnessChoice(chosen.smoothness, fits, chosen)
