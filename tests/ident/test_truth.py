"""Synthetic truth: known linear, Hammerstein, Wiener and WH systems with PWL nonlinearities."""

import pytest

from porosense import ident

KINDS = ("linear", "hammerstein", "wiener", "wh")
N = 600


@pytest.mark.parametrize("kind", KINDS)
def test_noise_free_search_selects_the_matching_structure(truth, make_recordings, kind):
    system = truth(kind)
    eu, ey, _ = make_recordings(system, N, seeds=(1, 2, 3))
    vu, vy, _ = make_recordings(system, N, seeds=(4, 5))
    result = ident.search(u=eu, y=ey, ts=system.ts, validation=(vu, vy), poles=(1, 2), n_breakpoints=5, progress=False)
    best = result.best
    print(result)
    assert best.structure == kind
    assert min(best.fit_validation) >= 99.0


@pytest.mark.parametrize("kind", KINDS)
def test_with_20_db_output_noise_the_fit_is_within_one_point_of_the_truth(truth, make_recordings, kind):
    system = truth(kind)
    eu, ey, _ = make_recordings(system, N, seeds=(11, 12, 13), snr_db=20.0)
    vu, vy, _ = make_recordings(system, N, seeds=(14, 15), snr_db=20.0)
    model = ident.make_model(kind, n_poles=2, n_zeros=1 if kind != "wh" else 0, n_breakpoints=5)
    model.fit(u=eu, y=ey, ts=system.ts)
    for u, y in zip(vu, vy):
        true_fit = ident.fit_percent(y, system.simulate(u)[:, 0])
        got = ident.fit_percent(y, model.predict(u=u))
        print(kind, f"model {got:.2f} % truth {true_fit:.2f} %")
        assert got >= true_fit - 1.0
