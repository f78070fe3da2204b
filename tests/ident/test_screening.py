"""Long records: candidates screened on a subset, finalists refined on every sample.

The records come from the known systems of conftest.py (random steps, 20 dB output noise), not
from the code under test.
"""

import numpy as np
import pytest

from porosense import ident
from porosense.ident.screening import screening_subset, settle_samples


def test_windows_spread_over_every_record_within_the_budget():
    lengths, skip, budget = [40_000, 10_000, 120_000], 300, 20_000
    sub = screening_subset(lengths, skip, budget, lambda cap: 500)
    assert sub is not None and sub.skip == 500
    assert sum(k == 2 for k, _, _ in sub.windows) > 1  # the longest record gets several windows
    assert abs(sub.samples - budget) <= 0.05 * budget
    for r, n in enumerate(lengths):
        own = [(a, b) for k, a, b in sub.windows if k == r]
        assert own, f"record {r} has no window"
        assert all(0 <= a < b <= n and b - a > sub.skip for a, b in own)
        # Spread: the windows of a record reach from its start to its end (one window: its start).
        assert min(a for a, _ in own) <= skip
        assert max(b for _, b in own) == n or len(own) == 1
    # Short records are taken whole: no subset.
    assert screening_subset([5_000, 5_000], 0, 20_000, lambda cap: 100) is None


def test_settle_time_of_the_slowest_pole():
    assert settle_samples([0.5, 0.9], cap=10_000) == int(np.ceil(np.log(0.01) / np.log(0.9)))
    assert settle_samples([0.9999], cap=1_000) == 1_000
    assert settle_samples([], cap=1_000) == 1


@pytest.fixture(scope="module")
def long_records(truth, make_recordings):
    system = truth("wh")
    us, ys, _ = make_recordings(system, 8_000, seeds=(71, 72, 73), snr_db=20.0)
    vu, vy, _ = make_recordings(system, 4_000, seeds=(74,), snr_db=20.0)
    return us, ys, (vu, vy), system.ts


def test_a_screened_search_selects_as_well_as_one_on_every_sample(long_records):
    """24,000 estimation samples screened on 6,000: the selected model is refined on all of them
    and validates within one standard error of the fit (the search's own tie band) of the model
    the search selects without screening. The screened search costs less CPU (printed)."""
    us, ys, val, ts = long_records
    kw = dict(u=us, y=ys, ts=ts, validation=val, structures=("linear", "wh"), poles=(1, 2, 3), n_breakpoints=6)
    kw.update(max_nfev=60, progress=False)
    full = ident.search(**kw, screen_samples=0)
    screened = ident.search(**kw, screen_samples=6_000)
    print(full)
    print(screened)
    print(f"CPU: every sample {full.cpu_seconds:.1f} s, screened {screened.cpu_seconds:.1f} s")
    assert "screened on" in screened.rule and "screened on" not in full.rule
    assert not screened.best.screened and screened.best.model.info["n_samples"] == sum(len(y) for y in ys)
    # Candidates left on the subset are in the table but never selected.
    assert any(c.screened for c in screened.candidates)
    assert screened.best.validation_fit >= full.best.validation_fit - full.tolerance(full.best)


def test_refine_continues_a_model_on_more_data(long_records):
    """A model fitted on the first quarter of the records and refined on all of them fits them at
    least as well as before, and the refined copy keeps the scaling it started with."""
    us, ys, _, ts = long_records
    scaling = ident.models.Scaling.of(us, ys)
    part = ident.Wiener(n_poles=2, n_zeros=1, n_breakpoints=6, max_nfev=40).fit(
        u=[u[:2000] for u in us], y=[y[:2000] for y in ys], ts=ts, scaling=scaling
    )
    sse = lambda m: sum(float(np.sum((m.predict(u=u) - y) ** 2)) for u, y in zip(us, ys))  # noqa: E731
    whole = part.refine(u=us, y=ys, max_nfev=40)
    assert sse(whole) <= sse(part)
    assert np.array_equal(whole.u_scale, part.u_scale) and whole.y_std == part.y_std
    assert whole.info["n_samples"] == sum(len(y) for y in ys) and whole.info["nfev"] > part.info["nfev"]
