"""Order search over structures, with the paper's selection rule.

Every (structure, n_poles, n_zeros) of the grid is estimated on the estimation recordings as
a task on a concurrent.futures Executor (a local process pool by default; a Dask
``distributed.Client`` works as well, :mod:`workers`); a WH order shares its task with the
Wiener and Hammerstein models of that order, which are its starting points. Candidates are
selected by :class:`SearchResult`'s rule (:class:`SearchOptions` ``criterion``).

How the cost stays linear in the data: staged (the default), every linear order is fitted
first and the nonlinear structures only at the best linear orders; on records longer than
``screen_samples`` the candidates are fitted on a subset (:mod:`screening`), scored on every
sample, and only the finalists (the best of each structure and those tied with the best) are
refined on all samples. A refinement runs in short pieces, so progress moves while it lasts.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from porosense.errors import InputError
from porosense.ident.bla_test import NonparametricBLA
from porosense.ident.candidates import Candidate, SearchResult, feasible, tie_tolerance
from porosense.ident.chain import Chain
from porosense.ident.models import NOISE_KINDS, Linear, Scaling, as_recordings, make_model
from porosense.ident.options import SearchOptions
from porosense.ident.screening import screening_subset, settle_samples
from porosense.ident.smoothness import skips_of
from porosense.ident.tasks import SearchData, best_member, cpu_of, fit_order, refine_candidate
from porosense.ident.workers import Cluster, Progress, Runner, Task

# Evaluations per piece of a finalist's refinement on all samples: the refinement is resumed
# piece after piece until it converges or spends the candidate's max_nfev, so that progress
# moves (a piece on 1,000,000 samples takes seconds, the whole refinement minutes).
REFINE_PIECE = 25
# Relative weights of a task's cost per sample, evaluation and parameter (for the estimate of
# the time left; calibrated on the running search's own CPU time).
STRUCTURE_COST = {"linear": 1.0, "hammerstein": 2.5, "wiener": 2.5, "wh": 6.0}
# One-sided level at which the nonparametric BLA refutes a linear order (bla_test).
BLA_ALPHA = 0.01


def search(
    *,
    u,
    y,
    ts: float,
    validation=None,
    options: SearchOptions | None = None,
    executor=None,
    progress=True,
    inputs=None,
    output: str = "y",
    input_unit=None,
    output_unit: str | None = None,
    **overrides,
) -> SearchResult:
    """Estimate the grid and select by the options' criterion (see :class:`SearchResult`).

    Parameters
    ----------
    u, y : list of arrays
        Estimation recordings: inputs (N, n_in) and output (N,) per recording, data units.
    ts : float
        Sample period in s.
    validation : (list, list) or None
        Validation inputs and outputs (scored past ``validation_skip``), or None.
    options : SearchOptions, optional
        How the search runs (default: ``porosense identify``'s defaults). Any of its fields may
        also be given as a keyword (``poles=(6,)``, ``criterion="aic"``) and overrides it.
    executor : Executor or distributed.Client, optional
        Where candidates run: default a process pool over the machine's cores (a single
        candidate runs in this process); any concurrent.futures Executor; a Dask client sends
        them to its cluster's workers (same result as the local pool).
    progress : bool or callable
        True: a progress bar; a callable receives a :class:`workers.Progress` at every step.
    inputs, output : names stored in every model.
    input_unit, output_unit : units stored in every model (:meth:`Model.fit`).
    **overrides
        SearchOptions fields replacing those of ``options`` (an unknown name is an InputError).

    Returns
    -------
    SearchResult
        Every candidate with its scores, the selected one, and how it was selected.

    Notes
    -----
    ``process_noise``: after the output-error search, the best Wiener and the best WH candidate
    are refitted with a Gaussian noise at g's input (:meth:`Model.predict`, started from the
    same models of their order) and scored by their expected output; each becomes the better of
    its process-noise and output-error fits (:func:`tasks.best_member`). When the estimation
    records are at least 4 realisations of one periodic input, the orders come from their
    nonparametric BLA instead: validation data carrying the same noise cannot rank them. Its
    statistics need whole records, so it fits every candidate on all samples.
    """
    opts = SearchOptions.with_overrides(options, **overrides)
    grid = opts.order_grid()
    data = _prepare(u, y, ts, validation, opts, inputs, output, input_unit, output_unit)
    t0, c0 = time.perf_counter(), time.process_time()
    cluster = Cluster.resolve(executor, tasks=len({(p, z) for _, p, z in grid}))
    bar = ProgressBar() if progress is True else None
    runner = Runner(cluster, bar if bar is not None else (progress or None))
    interrupted = True
    try:
        shared = cluster.share(data)
        if opts.process_noise:
            result = _process_noise_search(grid, data, shared, opts, runner)
        elif opts.staged and len({(p, z) for _, p, z in grid}) > 1:
            result = _staged(grid, data, shared, opts, runner)
        else:
            result = _whole_grid(grid, data, shared, opts, runner)
        interrupted = False
    finally:
        if bar is not None:
            bar.close()
        cluster.close(interrupted)
    result.seconds = time.perf_counter() - t0
    result.cpu_seconds = runner.cpu_done + (time.process_time() - c0 if cluster.own else 0.0)
    if data.screening and not opts.process_noise:
        result.holdout += ("; " if result.holdout else "") + data.subset_note
    return result


# ---------------------------------------------------------------------------- preparation


def _prepare(u, y, ts, validation, opts: SearchOptions, inputs, output, input_unit, output_unit) -> SearchData:
    """The records of the search, checked, with the screening subset when they are long."""
    us, ys = as_recordings(u, y)
    val = None
    if validation is not None:
        vu, vy = as_recordings(*validation)
        vskips = skips_of(opts.validation_skip, len(vy))
        if len(vskips) != len(vy) or any(len(v) - k < 2 for v, k in zip(vy, vskips)):
            raise InputError("every validation recording needs at least 2 scored samples after its skip")
        val = (vu, vy, vskips)
    if min(len(v) for v in ys) < opts.skip + 10:
        raise InputError(f"every recording needs at least skip + 10 = {opts.skip + 10} samples")
    data = SearchData(
        us=us,
        ys=ys,
        ts=ts,
        skip=opts.skip,
        val=val,
        scaling=Scaling.of(us, ys),
        fit_us=us,
        fit_ys=ys,
        fit_skip=opts.skip,
        inputs=tuple(inputs) if inputs is not None else None,
        output=output,
        input_unit=input_unit,
        output_unit=output_unit,
    )
    if opts.process_noise:
        return data
    subset = screening_subset([len(v) for v in ys], opts.skip, opts.screen_samples, lambda cap: _settle(data, cap))
    if subset is not None:
        data.fit_us, data.fit_ys = subset.take(us, ys)
        data.fit_skip = subset.skip
        data.subset_note = subset.describe()
    return data


def _settle(data: SearchData, cap: int) -> int:
    """Samples the slowest pole of a 2-pole linear fit (on the head of the records) takes to
    decay to 1 %, at most ``cap``: how long a screening window runs before it is scored."""
    heads_u, heads_y, left = [], [], 4 * cap
    for u, y in zip(data.us, data.ys):
        if left <= data.skip + 10:
            break
        heads_u.append(u[: left + data.skip])
        heads_y.append(y[: left + data.skip])
        left -= len(heads_y[-1])
    lin = Linear(n_poles=2, n_zeros=1, max_nfev=40, skip=data.skip).fit(
        u=heads_u, y=heads_y, ts=data.ts, scaling=data.scaling
    )
    assert lin.spec is not None  # fitted just above
    chain = Chain(lin.spec, lin.theta)
    poles = np.concatenate([_roots(den) for _, den, _ in chain.h1 if len(den)] or [np.zeros(0)])
    return settle_samples(poles, cap // 2)


def _roots(den) -> np.ndarray:
    return np.concatenate([np.roots(row[: 3 if row[2] else 2]) for row in den])


def _model_kwargs(opts: SearchOptions, skip: int) -> dict:
    """The make_model options every candidate of a search shares (the penalties only when set)."""
    kwargs: dict[str, int | float | bool] = {
        "n_breakpoints": opts.n_breakpoints,
        "delay": opts.delay,
        "starts": opts.starts,
        "max_nfev": opts.max_nfev,
        "skip": skip,
    }
    if opts.smoothness or opts.monotone:
        kwargs.update(smoothness=opts.smoothness, monotone=opts.monotone)
    return kwargs


def _weight(structures, n_poles: int, n_zeros: int, data: SearchData, opts: SearchOptions, samples=None) -> float:
    """Expected cost of fitting ``structures`` at one order, in sample x evaluation x parameter units."""
    n = samples if samples is not None else sum(len(y) for y in data.fit_ys)
    n_in = data.us[0].shape[1]
    params = n_in * (n_poles + n_zeros + 1) + 2 * opts.n_breakpoints
    return float(n * opts.max_nfev * params * sum(STRUCTURE_COST[s] for s in structures))


def _order_tasks(grid, data: SearchData, shared, opts: SearchOptions, linear: dict | None = None) -> list[Task]:
    """One task per order of ``grid`` (all its structures), most expensive first so that the
    workers stay busy to the end; ``linear`` maps an order to its fitted linear model."""
    groups: dict = {}
    for s, p, z in grid:
        groups.setdefault((p, z), []).append(s)
    kwargs = _model_kwargs(opts, data.fit_skip)
    tasks = []
    for (p, z), ss in groups.items():
        lin = (linear or {}).get((p, z))
        tasks.append(
            Task(fit_order, (tuple(ss), p, z, kwargs, shared, opts.criterion, lin), _weight(ss, p, z, data, opts))
        )
    tasks.sort(key=lambda t: -t.weight)
    return tasks


def _fit_grid(stage: str, grid, data, shared, opts, runner: Runner, linear=None) -> list[Candidate]:
    """The candidates of ``grid``, in the grid's order."""
    rank = {g: i for i, g in enumerate(grid)}
    results = runner.run(stage, _order_tasks(grid, data, shared, opts, linear), cpu_of)
    candidates = [c for r in results for c in r if (c.structure, c.n_poles, c.n_zeros) in rank]
    candidates.sort(key=lambda c: rank[(c.structure, c.n_poles, c.n_zeros)])
    return candidates


def _result(candidates, opts: SearchOptions, note: str = "") -> SearchResult:
    for c in candidates:
        c.feasible = feasible(c.model, opts.constraint, opts.size_fn, opts.max_bytes)
    holdout = opts.holdout + ("; " if opts.holdout and note else "") + note
    return SearchResult(candidates, 0.0, opts.tie_tol, opts.criterion, holdout)


# ------------------------------------------------------------------------------- searches


def _whole_grid(grid, data, shared, opts, runner: Runner) -> SearchResult:
    """Every structure at every order of the grid."""
    runner.planned = _refine_weight(data, opts, 4) if data.screening else 0.0
    candidates = _fit_grid("candidates", grid, data, shared, opts, runner)
    if data.screening:
        candidates = _refine_finalists(candidates, data, shared, opts, runner)
    return _result(candidates, opts)


def _staged(grid, data, shared, opts, runner: Runner) -> SearchResult:
    """Linear orders first, then the nonlinear structures at the best linear orders."""
    linear_grid = [g for g in grid if g[0] == "linear"] or [("linear", p, z) for _, p, z in grid]
    linear_grid = sorted(set(linear_grid), key=linear_grid.index)
    nonlinear = sorted({s for s, _, _ in grid if s != "linear"})
    n_orders = opts.staged_orders + 1
    median = sorted((p, z) for _, p, z in linear_grid)[len(linear_grid) // 2]
    runner.planned = n_orders * _weight(nonlinear, *median, data, opts) if nonlinear else 0.0
    runner.planned += _refine_weight(data, opts, len(nonlinear) + 2) if data.screening else 0.0
    first = _fit_grid("linear orders", linear_grid, data, shared, opts, runner)
    ranked = sorted(first, key=lambda c: -c.score(opts.criterion))
    chosen = _result(list(first), replace(opts, holdout="")).best
    orders = [(chosen.n_poles, chosen.n_zeros)]
    for c in ranked:
        if len(orders) >= n_orders:
            break
        if (c.n_poles, c.n_zeros) not in orders:
            orders.append((c.n_poles, c.n_zeros))
    second_grid = [(s, p, z) for s, p, z in grid if s != "linear" and (p, z) in orders]
    candidates = [c for c in first if ("linear", c.n_poles, c.n_zeros) in grid]
    linear = {(c.n_poles, c.n_zeros): c.model for c in first}
    runner.planned = _refine_weight(data, opts, len(nonlinear) + 2) if data.screening else 0.0
    if second_grid:
        candidates += _fit_grid("nonlinear structures", second_grid, data, shared, opts, runner, linear)
    if data.screening:
        candidates = _refine_finalists(candidates, data, shared, opts, runner)
    note = f"staged search: nonlinear structures at linear orders {', '.join(f'{p}p{z}z' for p, z in orders)}"
    return _result(candidates, opts, note)


def _refine_weight(data: SearchData, opts: SearchOptions, count: int) -> float:
    n = sum(len(y) for y in data.ys)
    params = data.us[0].shape[1] * 8 + 2 * opts.n_breakpoints
    return float(count * n * min(opts.max_nfev, 3 * REFINE_PIECE) * params * 2.0)


def finalists(candidates: list[Candidate], criterion: str, tie_tol: float = 0.01) -> list[Candidate]:
    """The candidates worth refining on all samples: the best of each structure by ``criterion``
    and every candidate within the tie band of the best (among feasible, unrefuted ones)."""
    pool = [c for c in candidates if c.feasible] or candidates
    pool = [c for c in pool if not c.refuted] or pool
    if not pool:
        return []
    top = max(pool, key=lambda c: c.score(criterion))
    tol = tie_tolerance(top, criterion, tie_tol)
    chosen = {id(c): c for c in pool if c.score(criterion) >= top.score(criterion) - tol}
    for s in {c.structure for c in pool}:
        best = max((c for c in pool if c.structure == s), key=lambda c: c.score(criterion))
        chosen[id(best)] = best
    return [c for c in candidates if id(c) in chosen]


def _refine_finalists(candidates, data, shared, opts, runner: Runner) -> list[Candidate]:
    """``candidates`` with the finalists refined on all samples (piece by piece, see
    REFINE_PIECE); the others stay screened (not selectable)."""
    for c in candidates:
        c.feasible = feasible(c.model, opts.constraint, opts.size_fn, opts.max_bytes)
    active = {id(c): [c, opts.max_nfev, c.cpu_seconds] for c in finalists(candidates, opts.criterion, opts.tie_tol)}
    n = sum(len(y) for y in data.ys)
    while active:
        keys = list(active)
        tasks = []
        for k in keys:
            c, left, _ = active[k]
            piece = min(REFINE_PIECE, left)
            tasks.append(Task(refine_candidate, (c, shared, piece), float(n * piece * c.n_params * 2.0)))
            active[k][1] = left - piece
        runner.planned = sum(float(n * min(v[1], REFINE_PIECE) * v[0].n_params * 2.0) for v in active.values())
        results = runner.run(f"refining {len(keys)} finalist(s) on all samples", tasks, cpu_of)
        for k, (refined, converged) in zip(keys, results):
            old, left, cpu = active[k]
            refined.cpu_seconds = cpu + refined.cpu_seconds
            refined.screened = False
            candidates[candidates.index(old)] = refined
            if converged or left <= 0:
                del active[k]
            else:
                active[k] = [refined, left, refined.cpu_seconds]
    runner.planned = 0.0
    return candidates


# --------------------------------------------------------------------------- process noise


def _process_noise_search(grid, data, shared, opts, runner: Runner) -> SearchResult:
    bla = NonparametricBLA.from_records(data.us, data.ys, opts.skip)
    oe = _bla_ordered_search(bla, grid, data, shared, opts, runner) if bla is not None else None
    if oe is None:
        oe = _staged(grid, data, shared, opts, runner) if opts.staged else _whole_grid(grid, data, shared, opts, runner)
    return _with_process_noise(oe, data, opts)


def _bla_ordered_search(bla: NonparametricBLA, grid, data, shared, opts, runner: Runner) -> SearchResult | None:
    """The search with orders ranked by the nonparametric BLA instead of validation data.

    The linear orders of the grid are fitted and tested against the BLA (bla_test) in order of
    their number of parameters; the BLA order is the one with the fewest parameters among those
    it does not refute at BLA_ALPHA (the lowest misfit among equals). Candidates at refuted
    orders are kept in the table but never selected (SearchResult). ``staged``: the linear
    orders stop at the first parameter count with an order the BLA does not refute, and the
    nonlinear structures are fitted at the BLA order only. None when the BLA refutes every
    linear order (the caller searches as without it)."""
    linear_grid = sorted({("linear", p, z) for _, p, z in grid}, key=lambda g: (g[1], g[2]))
    limit = bla.threshold(BLA_ALPHA)
    misfit, linear = {}, []
    # Orders by their number of parameters, all orders of one count at a time; staged, the
    # search stops at the first count with an order the BLA does not refute.
    for count in sorted({p + z for _, p, z in linear_grid}):
        batch = [g for g in linear_grid if g[1] + g[2] == count]
        linear += _fit_grid(f"linear orders of {count + 1} parameters", batch, data, shared, opts, runner)
        misfit.update({(c.n_poles, c.n_zeros): bla.misfit(c.model, data.us) for c in linear[-len(batch) :]})
        if opts.staged and any(misfit[(p, z)] <= limit for _, p, z in batch):
            break
    kept = [c for c in linear if misfit[(c.n_poles, c.n_zeros)] <= limit]
    if not kept:
        return None
    best = min(kept, key=lambda c: (c.n_params, misfit[(c.n_poles, c.n_zeros)]))
    order = (best.n_poles, best.n_zeros)
    second_grid = [(s, p, z) for s, p, z in grid if s != "linear" and ((p, z) == order or not opts.staged)]
    candidates = [c for c in linear if ("linear", c.n_poles, c.n_zeros) in grid]
    if second_grid:
        lin = {(c.n_poles, c.n_zeros): c.model for c in linear}
        candidates += _fit_grid("nonlinear structures", second_grid, data, shared, opts, runner, lin)
    for c in candidates:
        c.refuted = misfit.get((c.n_poles, c.n_zeros), 0.0) > limit
    note = (
        f"order from the {bla.describe()}: {order[0]}p{order[1]}z, the fewest parameters of the "
        f"{len(kept)} of {len(linear)} linear order(s) fitted it does not refute (misfit {misfit[order]:.3f} "
        f"<= {limit:.3f}, {100 * BLA_ALPHA:g} % one-sided); candidates at refuted orders not selected"
    )
    return _result(candidates, opts, note)


def _with_process_noise(result: SearchResult, data: SearchData, opts: SearchOptions) -> SearchResult:
    """``result`` with its best Wiener and best WH candidate (by its criterion, feasible first)
    refitted with a process noise at g's input, each replaced by the better of that fit and the
    output-error fits by :func:`tasks.best_member`. The refit starts from the linear, Wiener and
    Hammerstein models of the same order when the search estimated them, as the candidate did.

    Runs in this process, so the WH's builds are refined on a pool of the machine's cores
    (:func:`porosense.ident.process_noise.map_builds`)."""
    candidates = list(result.candidates)
    kwargs = _model_kwargs(opts, opts.skip)
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
        model.fit(**data.fit_kwargs(full=True), **parts)
        best = best_member(structure, top.n_poles, top.n_zeros, model, data, result.criterion, others=[top])
        if best is not top:
            best.seconds = top.seconds + time.perf_counter() - t1
            best.cpu_seconds = top.cpu_seconds + time.process_time() - c1
            best.feasible = feasible(best.model, opts.constraint, opts.size_fn, opts.max_bytes)
            best.refuted = top.refuted
            candidates[candidates.index(top)] = best
        method = model.info.get("process_noise", {}).get("method", "")
        kept_model = best.model
        assert kept_model is not None and kept_model.spec is not None  # best_member scores fitted models
        kept = (
            "process noise rejected by the period differences, output error kept"
            if method.endswith("rejected")
            else "process noise undetermined by the records, output error kept"
            if method.endswith("undetermined")
            else "process noise"
            if kept_model.spec.g_noise
            else "output error kept"
        )
        refitted.append(f"{structure} {top.n_poles}p{top.n_zeros}z ({kept})")
    note = (
        "process noise fitted for " + ", ".join(refitted) if refitted else "no Wiener or WH candidate for process noise"
    )
    return SearchResult(
        candidates,
        result.seconds,
        result.tie_tol,
        result.criterion,
        result.holdout + ("; " if result.holdout else "") + note,
    )


# -------------------------------------------------------------------------------- progress


class ProgressBar:
    """A tqdm bar over the tasks of the current stage, with the estimated time left."""

    def __init__(self):
        self.bar = None
        self.stage = None

    def __call__(self, p: Progress) -> None:
        from tqdm.auto import tqdm

        bar = self.bar
        if p.stage != self.stage or bar is None:
            self.close()
            self.stage = p.stage
            bar = self.bar = tqdm(total=p.total, desc=p.stage, unit="task", leave=False)
        bar.n = p.done
        if p.eta_seconds is not None:
            bar.set_postfix_str(f"about {duration_text(p.eta_seconds)} left", refresh=False)
        bar.refresh()
        if p.done == p.total:
            self.close()

    def close(self) -> None:
        """Close the current stage's bar."""
        if self.bar is not None:
            self.bar.close()
        self.bar, self.stage = None, None


def duration_text(seconds: float) -> str:
    """``seconds`` (s) as a short text: seconds below 90 s, minutes above."""
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"
