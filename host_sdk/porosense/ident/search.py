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
from porosense.ident.models import KINDS, Model, as_recordings, make_model

STRUCTURES = tuple(KINDS)


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
        return {"structure": self.structure, "n_poles": self.n_poles, "n_zeros": self.n_zeros,
                "mean_fit": self.mean_fit, "mean_rms": self.mean_rms,
                "fit_estimation": self.fit_estimation, "fit_validation": self.fit_validation,
                "rms_estimation": self.rms_estimation, "rms_validation": self.rms_validation,
                "aic": self.aic, "bic": self.bic, "n_params": self.n_params,
                "seconds": self.seconds, "cpu_seconds": self.cpu_seconds, "feasible": self.feasible}


@dataclass
class SearchResult:
    """All candidates of a search; ``best`` by mean fit (the paper's rule, ties within
    ``tie_tol`` % points go to the smaller model), ``best_per_structure`` for the ranking."""

    candidates: list
    seconds: float
    tie_tol: float = 0.01

    @property
    def feasible(self) -> list:
        return [c for c in self.candidates if c.feasible]

    @property
    def best(self) -> Candidate:
        """Highest mean fit; among candidates within ``tie_tol`` points of it, the fewest parameters."""
        pool = self.feasible or self.candidates
        top = max(c.mean_fit for c in pool)
        near = [c for c in pool if c.mean_fit >= top - self.tie_tol]
        return min(near, key=lambda c: (c.n_params, -c.mean_fit))

    @property
    def model(self) -> Model:
        """The selected model."""
        return self.best.model

    def best_per_structure(self) -> dict:
        out = {}
        for c in self.feasible or self.candidates:
            if c.structure not in out or c.mean_fit > out[c.structure].mean_fit:
                out[c.structure] = c
        return out

    def table(self) -> list[dict]:
        """One plain dict per candidate, best first (no pandas needed)."""
        rows = [c.to_dict() for c in self.candidates]
        return sorted(rows, key=lambda r: -r["mean_fit"] if np.isfinite(r["mean_fit"]) else np.inf)

    def to_dict(self) -> dict:
        best = self.best
        return {"best": best.to_dict(), "seconds": self.seconds,
                "best_per_structure": {k: v.to_dict() for k, v in self.best_per_structure().items()},
                "candidates": self.table()}

    def __str__(self) -> str:
        lines = [f"{'structure':<12}{'poles':>6}{'zeros':>6}{'mean fit %':>12}{'mean RMS %':>12}"
                 f"{'AIC':>12}{'BIC':>12}"]
        for c in sorted(self.best_per_structure().values(), key=lambda c: -c.mean_fit):
            lines.append(f"{c.structure:<12}{c.n_poles:>6}{c.n_zeros:>6}{c.mean_fit:>12.2f}"
                         f"{c.mean_rms:>12.2f}{c.aic:>12.4g}{c.bic:>12.4g}")
        lines.append(f"selected: {self.best.structure} ({self.best.n_poles} poles, {self.best.n_zeros} zeros), "
                     f"{len(self.candidates)} candidates in {self.seconds:.1f} s")
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


def _score(structure, n_poles, n_zeros, model, kwargs, fit_args, val, seconds, cpu_seconds) -> Candidate:
    est = model.score(u=fit_args["u"], y=fit_args["y"], skip=kwargs["skip"])
    vs = model.score(u=val[0], y=val[1], skip=val[2]) if val else {"fit": [], "rms": []}
    return Candidate(structure, n_poles, n_zeros, est["fit"], vs["fit"], est["rms"], vs["rms"],
                     model.aic, model.bic, model.n_params, seconds, True, model, cpu_seconds)


def _fit_candidate(structure, n_poles, n_zeros, kwargs, fit_args, val):
    """Worker: estimate one model and score it (top level so process pools can pickle it)."""
    t0, c0 = time.perf_counter(), time.process_time()
    model = make_model(structure, n_poles=n_poles, n_zeros=n_zeros, **kwargs)
    model.fit(**fit_args)
    return _score(structure, n_poles, n_zeros, model, kwargs, fit_args, val,
                  time.perf_counter() - t0, time.process_time() - c0)


def _fit_wh_group(structures, n_poles, n_zeros, kwargs, fit_args, val) -> list:
    """Worker: the Wiener and Hammerstein models of one order, then the WH model started from them.

    Returns the candidates of ``structures`` (which contains "wh"). The WH candidate is the
    member with the best selection score among the jointly refined builds and their two
    starting points (WH models with identity blocks equal to the Wiener and Hammerstein
    models), so it scores at least as well as both. The WH candidate's times
    are those of its joint refinements plus the parts that are not candidates themselves.
    """
    out, extra = [], [0.0, 0.0]
    parts = {}
    for s in ("wiener", "hammerstein"):
        t0, c0 = time.perf_counter(), time.process_time()
        parts[s] = make_model(s, n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args)
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        if s in structures:
            out.append(_score(s, n_poles, n_zeros, parts[s], kwargs, fit_args, val, dt, dc))
        else:
            extra[0] += dt
            extra[1] += dc
    t0, c0 = time.perf_counter(), time.process_time()
    wh = make_model("wh", n_poles=n_poles, n_zeros=n_zeros, **kwargs).fit(**fit_args, **parts)
    # The refined model and the WH members it was refined from, scored by the selection rule:
    # the WH candidate of this order is never below the Wiener and Hammerstein candidates.
    members = [_score("wh", n_poles, n_zeros, m, kwargs, fit_args, val, 0.0, 0.0)
               for m in [wh] + wh.alternative_models()]
    best = max(members, key=lambda c: c.mean_fit)
    best.model.alternatives = []
    best.seconds = time.perf_counter() - t0 + extra[0]
    best.cpu_seconds = time.process_time() - c0 + extra[1]
    out.append(best)
    return out


def _tasks(grid) -> list[tuple[tuple[str, ...], int, int]]:
    """Group the grid into tasks: a WH order together with the Wiener and Hammerstein models of
    that order (the WH starts from them), every other candidate alone."""
    orders_with_wh = {(p, z) for s, p, z in grid if s == "wh"}
    groups: dict = {}
    tasks = []
    for s, p, z in grid:
        if (p, z) in orders_with_wh and s in ("wh", "wiener", "hammerstein"):
            if (p, z) not in groups:
                groups[(p, z)] = []
                tasks.append(((p, z), groups[(p, z)]))
            groups[(p, z)].append(s)
        else:
            tasks.append(((p, z), [s]))
    return [(tuple(ss), p, z) for (p, z), ss in tasks]


def _run_task(structures, n_poles, n_zeros, kwargs, fit_args, val) -> list:
    if "wh" in structures:
        return _fit_wh_group(structures, n_poles, n_zeros, kwargs, fit_args, val)
    return [_fit_candidate(structures[0], n_poles, n_zeros, kwargs, fit_args, val)]


def search(*, u, y, ts: float, validation=None, structures=STRUCTURES, poles=range(1, 11), zeros=None,
           n_breakpoints: int = 10, delay: int = 0, starts: int = 2, max_nfev: int = 100, skip: int = 0,
           inputs=None, output: str = "y", executor: Executor | None = None, progress: bool = True,
           constraint=None, size_fn=None, max_bytes: int | None = None, grid=None,
           tie_tol: float = 0.01, validation_skip: int = 0) -> SearchResult:
    """Estimate the whole grid and select by mean fit over estimation + validation recordings.

    u, y: estimation recordings (lists of (N, n_in) and (N,)); validation: (u_list, y_list) or
    None; ts in s. ``constraint(structure) -> bool`` or ``size_fn(structure) -> bytes`` with
    ``max_bytes`` mark candidates infeasible (they are reported, never selected unless no
    candidate is feasible). ``executor``: any concurrent.futures Executor; default a process
    pool over the machine's cores (a single candidate runs in this process). ``skip`` and
    ``validation_skip``: leading samples of each recording simulated but not scored. ``grid``: an
    explicit list of (structure, n_poles, n_zeros) instead of structures/poles/zeros.
    """
    us, ys = as_recordings(u, y)
    val = None
    if validation is not None:
        vu, vy = as_recordings(*validation)
        val = (vu, vy, int(validation_skip))
    grid = list(grid) if grid is not None else order_grid(structures, poles, zeros)
    if not grid:
        raise InputError("empty order grid")
    rank = {g: i for i, g in enumerate(grid)}
    kwargs = {"n_breakpoints": n_breakpoints, "delay": delay, "starts": starts, "max_nfev": max_nfev, "skip": skip}
    fit_args = {"u": us, "y": ys, "ts": ts, "inputs": inputs, "output": output}
    # Most expensive first so that the pool stays busy to the end.
    weight = {"wh": 2, "hammerstein": 2, "wiener": 2, "linear": 1}
    tasks = _tasks(grid)
    tasks.sort(key=lambda t: -(sum(weight[s] for s in t[0]) + (2 if "wh" in t[0] else 0)) * (t[1] + t[2] + 1))
    if executor is None and len(tasks) == 1:
        t0 = time.perf_counter()
        candidates = _run_task(*tasks[0], kwargs, fit_args, val)
        for c in candidates:
            c.feasible = _feasible(c.model, constraint, size_fn, max_bytes)
        candidates.sort(key=lambda c: rank[(c.structure, c.n_poles, c.n_zeros)])
        return SearchResult(candidates, time.perf_counter() - t0, tie_tol)
    own = executor is None
    if own:
        executor = ProcessPoolExecutor(max_workers=min(os.cpu_count() or 1, len(tasks)))
    t0 = time.perf_counter()
    candidates = []
    try:
        futures = [executor.submit(_run_task, ss, p, z, kwargs, fit_args, val) for ss, p, z in tasks]
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
    return SearchResult(candidates, time.perf_counter() - t0, tie_tol)


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
