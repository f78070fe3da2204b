"""Order search: any executor, device constraint, report objects."""

from concurrent.futures import ThreadPoolExecutor

import matplotlib
import numpy as np
import pytest

from porosense import ident

matplotlib.use("Agg")


@pytest.fixture
def problem(truth, make_recordings):
    system = truth("hammerstein")
    eu, ey, _ = make_recordings(system, 400, seeds=(31, 32))
    vu, vy, _ = make_recordings(system, 400, seeds=(33,))
    return eu, ey, (vu, vy), system.ts


def test_grid_counts_zeros_below_poles():
    grid = ident.order_grid(("linear", "wh"), poles=range(1, 11))
    assert len(grid) == 2 * 55
    assert all(z < p for _, p, z in grid)


def test_search_runs_on_any_executor_and_reports_criteria(problem):
    eu, ey, val, ts = problem
    with ThreadPoolExecutor(2) as pool:
        result = ident.search(
            u=eu,
            y=ey,
            ts=ts,
            validation=val,
            structures=("linear", "hammerstein"),
            poles=(1, 2),
            n_breakpoints=5,
            executor=pool,
            progress=False,
        )
    assert len(result.candidates) == 6
    assert all(np.isfinite(c.aic) and np.isfinite(c.bic) for c in result.candidates)
    assert result.best.structure == "hammerstein" and result.best.mean_fit > 99.0
    d = result.to_dict()
    assert d["best"]["structure"] == "hammerstein" and len(d["candidates"]) == 6
    ax = result.plot()
    assert len(ax.get_lines()) == 2


def test_device_constraint_excludes_models_over_budget(problem):
    eu, ey, val, ts = problem
    budget = 70  # bytes: enough for a small linear model, not for a 5-breakpoint Hammerstein
    result = ident.search(
        u=eu,
        y=ey,
        ts=ts,
        validation=val,
        structures=("linear", "hammerstein"),
        poles=(1, 2),
        n_breakpoints=5,
        progress=False,
        size_fn=ident.approx_blob_bytes,
        max_bytes=budget,
        executor=ThreadPoolExecutor(2),
    )
    sizes = {
        (c.structure, c.n_poles, c.n_zeros): ident.approx_blob_bytes(c.model.to_structure()) for c in result.candidates
    }
    assert any(not c.feasible for c in result.candidates)
    assert sizes[(result.best.structure, result.best.n_poles, result.best.n_zeros)] <= budget
    assert result.best.structure == "linear"


def test_predicate_constraint(problem):
    eu, ey, val, ts = problem
    result = ident.search(
        u=eu,
        y=ey,
        ts=ts,
        validation=val,
        structures=("linear", "hammerstein"),
        poles=(1, 2),
        n_breakpoints=5,
        progress=False,
        executor=ThreadPoolExecutor(2),
        constraint=lambda s: s.outputs[0].branches[0].h1.n_sections <= 1 and s.outputs[0].kind == "linear",
    )
    assert result.best.structure == "linear"
    assert sum(c.feasible for c in result.candidates) == 3
