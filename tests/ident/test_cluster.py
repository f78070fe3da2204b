"""The order search on a Dask cluster (the optional ``cluster`` extra): the same candidates and the
same model as on the local process pool, from Python and from ``identify --scheduler``."""

import json

import numpy as np
import pytest

from porosense import ident

distributed = pytest.importorskip("distributed", reason="Dask distributed (porosense[cluster]) is not installed")


@pytest.fixture(scope="module")
def cluster():
    with (
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc,
        distributed.Client(lc) as client,
    ):
        yield lc, client


def test_search_on_a_local_cluster_gives_the_local_pools_model(cluster, truth, make_recordings):
    _, client = cluster
    system = truth("hammerstein")
    eu, ey, _ = make_recordings(system, 600, seeds=(51, 52))
    vu, vy, _ = make_recordings(system, 600, seeds=(53,))
    kw = dict(u=eu, y=ey, ts=system.ts, validation=(vu, vy), structures=("linear", "hammerstein"), poles=(1, 2, 3))
    kw.update(n_breakpoints=5, max_nfev=30, progress=False)
    local = ident.search(**kw)
    remote = ident.search(**kw, executor=client)
    key = lambda r: [(c.structure, c.n_poles, c.n_zeros) for c in r.candidates]  # noqa: E731
    assert key(remote) == key(local)
    for a, b in zip(remote.candidates, local.candidates):
        assert np.array_equal(a.model.theta, b.model.theta), (a.structure, a.n_poles, a.n_zeros)
    assert (remote.best.structure, remote.best.n_poles, remote.best.n_zeros) == (
        local.best.structure,
        local.best.n_poles,
        local.best.n_zeros,
    )


def test_identify_with_a_scheduler_saves_the_local_model(cluster, tmp_path, truth, make_recordings):
    from porosense.cli import main

    lc, _ = cluster
    system = truth("wiener")
    us, ys, _ = make_recordings(system, 500, seeds=(61, 62, 63))
    paths = []
    for k, (u, y) in enumerate(zip(us, ys)):
        p = tmp_path / f"rec{k}.csv"
        t = np.arange(len(y)) * system.ts
        p.write_text(
            "t_s,u,y\n"
            + "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u[:, 0].tolist(), y.tolist()))
            + "\n"
        )
        paths.append(str(p))
    base = ["identify", "--data", *paths, "--input", "u", "--output", "y", "--structure", "wiener"]
    base += ["--max-poles", "2", "--breakpoints", "5", "--max-iter", "30", "--smoothness", "0", "--quiet"]
    assert main([*base, "--out", str(tmp_path / "local.json")]) == 0
    assert main([*base, "--out", str(tmp_path / "dask.json"), "--scheduler", lc.scheduler_address]) == 0
    a = json.loads((tmp_path / "local.json").read_text())["models"][0]
    b = json.loads((tmp_path / "dask.json").read_text())["models"][0]
    assert a["theta"] == b["theta"] and a["orders"] == b["orders"]


def test_an_unreachable_scheduler_is_one_line(tmp_path, capsys):
    from porosense.cli import main

    p = tmp_path / "rec.csv"
    rng = np.random.default_rng(0)
    u = rng.standard_normal(300)
    p.write_text("t_s,u,y\n" + "\n".join(f"{k * 0.01!r},{a!r},{0.5 * a!r}" for k, a in enumerate(u.tolist())) + "\n")
    rc = main(
        ["identify", "--data", str(p), "--input", "u", "--output", "y", "--poles", "1", "--quiet"]
        + ["--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "m.json")]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err[0], err
    assert not (tmp_path / "m.json").exists()
