"""Order search over structures, with the paper's selection rule.

Every (structure, n_poles, n_zeros) of the grid is estimated on the estimation recordings as
one task on a concurrent.futures Executor (a local process pool by default; a Dask client's
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


def _fit_candidate(structure, n_poles, n_zeros, kwargs, fit_args, val):
    """Worker: estimate one model and score it (top level so process pools can pickle it)."""
    t0, c0 = time.perf_counter(), time.process_time()
    model = make_model(structure, n_poles=n_poles, n_zeros=n_zeros, **kwargs)
    model.fit(**fit_args)
    est = model.score(u=fit_args["u"], y=fit_args["y"], skip=kwargs["skip"])
    vs = model.score(u=val[0], y=val[1], skip=val[2]) if val else {"fit": [], "rms": []}
    return Candidate(structure, n_poles, n_zeros, est["fit"], vs["fit"], est["rms"], vs["rms"],
                     model.aic, model.bic, model.n_params, time.perf_counter() - t0, True, model,
                     time.process_time() - c0)


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
    weight = {"wh": 4, "hammerstein": 2, "wiener": 2, "linear": 1}
    grid.sort(key=lambda g: -(weight[g[0]] * (g[1] + g[2] + 1)))
    if executor is None and len(grid) == 1:
        t0 = time.perf_counter()
        c = _fit_candidate(*grid[0], kwargs, fit_args, val)
        c.feasible = _feasible(c.model, constraint, size_fn, max_bytes)
        return SearchResult([c], time.perf_counter() - t0, tie_tol)
    own = executor is None
    if own:
        executor = ProcessPoolExecutor(max_workers=os.cpu_count() or 1)
    t0 = time.perf_counter()
    candidates = []
    try:
        futures = [executor.submit(_fit_candidate, s, p, z, kwargs, fit_args, val) for s, p, z in grid]
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(futures), desc="order search", unit="model", leave=False)
        for fut in as_completed(futures):
            candidates.append(fut.result())
            if bar is not None:
                bar.update(1)
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
