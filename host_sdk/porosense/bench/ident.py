"""Identification benchmark (``porosense bench ident [--only PART...] [--wh2009 PATH]``).

Parts (all by default):
  grid      the paper's order grid: 4 structures x poles 1..10 x zeros < poles, 2 starts, the
            paper's rule, on a SISO problem of 5 recordings x 60 s at 50 Hz (3 estimation, 2
            validation) from a known Wiener-Hammerstein system driven by vacuum-step-like inputs.
  oe        a linear output-error fit on 10,000 samples against SIPPY's OE and SysIdentPy's
            polynomial NARX (when installed): times, their ratios and the simulation fits.
  scaling   the default search (staged, 4 structures, poles <= 10) against the number of samples
            (10k, 100k, 1M) on the system of ``grid``: CPU and wall time, peak memory.
  cluster   the same default search (100k samples) on a Dask LocalCluster with 1 and with 2
            workers, and on the local pool: times and whether the models agree.
  3dof      the default search for theta_x of the 3-DoF segment (3 inputs, the paper's set
            simulated at 100 Hz, the last file held out).
  measured  the measured benchmarks (when the data folder is present): the WH benchmark with
            process noise (default search on 8 realisations, 2 validate, test on the multisine;
            SysIdentPy's NARX on the same records), the noise level from repeated periods, the
            suite's process-noise search at its full size, and Bouc-Wen.
  builds    the measured WH benchmark's process-noise builds at one order, side by side
            (:mod:`porosense.bench.wh_noise`; only when asked for).
  whsearch  the default search with process noise on a range of its realisations
            (:mod:`porosense.bench.wh_noise`; only when asked for).
  wh2009    the 2009 Wiener-Hammerstein benchmark from the user's copy (``--wh2009 PATH``,
            :mod:`porosense.bench.wh2009`), beside the published table.
``size="small"`` runs reduced versions of oe, grid and scaling (poles <= 2 on 5 x 20 s, 2,000
samples for oe, 2k/5k for scaling); ``--only cluster`` at the small size runs linear and
Hammerstein up to 3 poles on 4k samples.

Times: wall time, and CPU time summed over this process and its worker processes
(resource.getrusage); on a shared machine the CPU time is the figure to compare with a bound
"on 2 cores" (CPU / 2), the wall time depends on the load (printed). A Dask cluster's
workers report their own CPU time (resource.getrusage in each worker process).
"""

from __future__ import annotations

import os
import resource
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import signal

from porosense.data import read_table
from porosense.ident import Linear, WienerHammerstein, fit_percent, rmse, search
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

FS_HZ = 50.0


def truth_system() -> EstimatorStructure:
    """A WH system shaped like dR (fraction) -> strain (%): saturating g between two lags."""
    g = PiecewiseLinear(np.array([-1.0, -0.6, -0.3, -0.1, 0.0, 0.1]), np.array([30.0, 26.0, 17.0, 5.0, 0.0, -1.0]))
    h1 = SOSCascade.from_tf([0.12], [1.0, -0.88])
    h2 = SOSCascade.from_tf([0.02, 0.015], [1.0, -1.62, 0.655])
    return EstimatorStructure(("dR_0",), (OutputChain("strain_0", (Branch(0, h1),), g=g, h2=h2),), ts=1 / FS_HZ)


def step_recording(seed: int, seconds: float = 60.0, noise: float = 0.05):
    """Vacuum-step-like input (random levels, 10 s on / 10 s off) and the truth's noisy output."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS_HZ)
    t = np.arange(n) / FS_HZ
    u = np.zeros(n)
    for start in np.arange(0.0, seconds, 20.0):
        on = (t >= start + 2.0) & (t < start + 12.0)
        u[on] = -rng.uniform(0.1, 0.9)
    u = signal.lfilter([0.1], [1.0, -0.9], u)  # pneumatic lag of the chamber
    y = truth_system().simulate(u[:, None])[:, 0]
    return u[:, None], y + noise * rng.standard_normal(n)


def grid_benchmark(size: str) -> dict:
    seconds_each = 60.0 if size == "full" else 20.0
    recs = [step_recording(seed, seconds_each) for seed in range(5)]
    est, val = recs[:3], recs[3:]
    poles = range(1, 11) if size == "full" else range(1, 3)
    t0, c0 = time.perf_counter(), _cpu()
    result = search(
        u=[r[0] for r in est],
        y=[r[1] for r in est],
        ts=1 / FS_HZ,
        validation=([r[0] for r in val], [r[1] for r in val]),
        poles=poles,
        starts=2,
        criterion="paper",
        staged=False,
        progress=False,
    )
    seconds = time.perf_counter() - t0
    best = result.best
    per = {k: round(v.mean_fit, 3) for k, v in result.best_per_structure().items()}
    cpu = _cpu() - c0
    return {
        "grid_models": len(result.candidates),
        "grid_seconds": seconds,
        "grid_cores": os.cpu_count(),
        "grid_cpu_seconds": cpu,
        "grid_seconds_each": seconds_each,
        "load_average_1min": os.getloadavg()[0],
        "grid_samples": int(sum(len(r[1]) for r in recs)),
        "grid_best": f"{best.structure} {best.n_poles}p{best.n_zeros}z",
        "grid_best_fit": best.mean_fit,
        "grid_best_fit_per_structure": per,
    }


def oe_problem(n: int, seed: int = 0):
    """Second-order OE system with a one-sample delay, white input, output noise (SNR ~ 20 dB)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    y0 = signal.lfilter([0.0, 0.2, 0.1], [1.0, -1.2, 0.5], u)
    return u, y0, y0 + 0.1 * np.std(y0) * rng.standard_normal(n)


def oe_benchmark(size: str) -> dict:
    n = 10_000 if size == "full" else 2_000
    u, y0, y = oe_problem(n)
    t0 = time.perf_counter()
    model = Linear(n_poles=2, n_zeros=1, delay=1).fit(u=u[:, None], y=y, ts=1.0)
    ours_s = time.perf_counter() - t0
    ours_fit = fit_percent(y, model.predict(u=u[:, None]))
    out = {
        "oe_samples": n,
        "oe_porosense_seconds": ours_s,
        "oe_porosense_fit": ours_fit,
        "oe_porosense_fit_noise_free": fit_percent(y0, model.predict(u=u[:, None])),
    }
    narx = narx_fit(u, y, u, y)
    if narx is None:
        out["oe_narx"] = "sysidentpy not installed"
    else:
        out.update(
            {
                "oe_narx_seconds": narx["wall_s"],
                "oe_narx_fit": fit_percent(y, narx["yhat"]),
                "oe_narx_fit_noise_free": fit_percent(y0, narx["yhat"]),
                "oe_narx_terms": narx["terms"],
            }
        )
    try:
        from sippy_unipi import system_identification
    except ImportError:
        out["oe_sippy"] = "sippy_unipi not installed"
        return out
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # OE_orders = [nb, nf, extra delay]; SIPPY's OE already delays the input by one sample.
        sip = system_identification(y, u, "OE", OE_orders=[2, 2, 0], tsample=1.0)
    sippy_s = time.perf_counter() - t0
    import control

    yhat = control.forced_response(sip.G, U=u).outputs
    out.update(
        {
            "oe_sippy_seconds": sippy_s,
            "oe_sippy_fit": fit_percent(y, yhat),
            "oe_sippy_fit_noise_free": fit_percent(y0, yhat),
            "oe_speedup": sippy_s / ours_s,
        }
    )
    return out


def _cpu() -> float:
    """CPU seconds of this process and of its finished (waited-for) worker processes."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def shared_data_folder() -> Path | None:
    """POROSENSE_SHARED_DATA, else <repo>/../shared/data, else /work/shared/data (None if absent)."""
    env = os.environ.get("POROSENSE_SHARED_DATA")
    repo = Path(__file__).resolve().parents[3]
    for p in ([Path(env)] if env else []) + [repo.parent / "shared" / "data", Path("/work/shared/data")]:
        if p.is_dir():
            return p
    return None


def _search_records(n: int):
    """4 recordings of ``n`` samples in all of the ``grid`` system: 3 estimate, 1 validates."""
    recs = [step_recording(seed, n / 4 / FS_HZ) for seed in range(4)]
    return [r[0] for r in recs[:3]], [r[1] for r in recs[:3]], ([recs[3][0]], [recs[3][1]])


def _default_search(n: int, executor=None, progress=False, **options) -> tuple:
    """(result, wall s, CPU s of this process and its children) of the default search (or of
    the search with ``options`` changed)."""
    us, ys, val = _search_records(n)
    t0, c0 = time.perf_counter(), _cpu()
    res = search(u=us, y=ys, ts=1 / FS_HZ, validation=val, executor=executor, progress=progress, **options)
    return res, time.perf_counter() - t0, _cpu() - c0


def scaling_benchmark(size: str) -> dict:
    """Default search (staged, 4 structures, poles <= 10) time against the number of samples."""
    counts = (10_000, 100_000, 1_000_000) if size == "full" else (2_000, 5_000)
    rows = []
    for n in counts:
        res, wall, cpu = _default_search(n)
        rows.append(
            {
                "samples": n,
                "wall_s": wall,
                "cpu_s": cpu,
                "load_average_1min": os.getloadavg()[0],
                "peak_rss_mb": _peak_rss_mb(),
                "selected": f"{res.best.structure} {res.best.n_poles}p{res.best.n_zeros}z",
                "validation_fit": res.best.validation_fit,
                "candidates": len(res.candidates),
                "screening": "screened" in res.rule,
            }
        )
    return {"scaling": rows}


def _peak_rss_mb() -> float:
    """The largest resident set of this process or of any of its finished children, MB."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return max(a.ru_maxrss, b.ru_maxrss) / 1024.0


def _worker_cpu(client) -> float:
    """CPU seconds of every Dask worker process so far."""

    def own():
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    return float(sum(client.run(own).values()))


# The small size's search on the cluster: linear and Hammerstein up to 3 poles (the full size
# runs the default search).
SMALL_CLUSTER_SEARCH = {"structures": ("linear", "hammerstein"), "poles": (1, 2, 3), "max_nfev": 60}


def cluster_benchmark(size: str) -> dict:
    """The same search (full size: the default one on 100,000 samples) on the local pool, then on
    a Dask LocalCluster of 1 and of 2 worker processes: times and whether every cluster gives the
    local pool's model."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        return {"cluster": "dask distributed not installed (pip install 'porosense[cluster]')"}
    n = 100_000 if size == "full" else 4_000
    options = {} if size == "full" else SMALL_CLUSTER_SEARCH
    local, wall, cpu = _default_search(n, **options)
    rows = [{"workers": "local pool", "wall_s": wall, "cpu_s": cpu, "same_model": True}]
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as lc:
            with Client(lc) as client:
                w0 = _worker_cpu(client)
                res, wall, cpu = _default_search(n, executor=client, **options)
                w1 = _worker_cpu(client)
        same = (res.best.structure, res.best.n_poles, res.best.n_zeros) == (
            local.best.structure,
            local.best.n_poles,
            local.best.n_zeros,
        ) and np.array_equal(res.model.theta, local.model.theta)
        rows.append({"workers": workers, "wall_s": wall, "cpu_s": cpu + w1 - w0, "same_model": bool(same)})
    what = "default search" if size == "full" else "linear and Hammerstein search, poles <= 3"
    return {"cluster": {"samples": n, "search": what, "load_average_1min": os.getloadavg()[0], "rows": rows}}


def three_dof_benchmark() -> dict:
    """The default search of ``porosense identify`` for theta_x of the 3-DoF segment (inputs
    dR_0..2 in %, the paper's set simulated at 100 Hz, the last file held out)."""
    from porosense import ident
    from porosense.sim import run_experiment

    names = [f"sequential_{lv}" for lv in (10, 20, 40, 60)] + ["two_level"]
    recs = [run_experiment("3dof", e, rate_hz=100.0, seed=0) for e in names]
    us = [np.column_stack([r[f"dR_{i}"] for i in range(3)]) for r in recs]
    ys = [r["theta_x"] for r in recs]
    t0, c0 = time.perf_counter(), _cpu()
    found = ident.identify(u=us, y=ys, ts=0.01, inputs=("dR_0", "dR_1", "dR_2"), outputs=("theta_x",), progress=False)
    best = found.results[0].best
    return {
        "three_dof": {
            "samples": int(sum(len(y) for y in ys)),
            "wall_s": time.perf_counter() - t0,
            "cpu_s": _cpu() - c0,
            "load_average_1min": os.getloadavg()[0],
            "selected": f"{best.structure} {best.n_poles}p{best.n_zeros}z",
            "validation_fit": best.validation_fit,
        }
    }


def narx_fit(u_est, y_est, u_test, y_test, lags: int = 2, degree: int = 2) -> dict | None:
    """SysIdentPy's polynomial NARX (FROLS, AIC term selection, least squares) fitted on one
    record and simulated free-run on another (its first ``lags`` outputs as initial state).

    SysIdentPy pins an older numpy than porosense: it runs in its own environment
    (``.venv-peers``, made by tools/bootstrap.sh, or the interpreter named by
    ``POROSENSE_PEER_PYTHON``) through tools/peers/narx_peer.py, or in this process when it is
    importable here. Returns {"yhat" (output units), "wall_s", "cpu_s" (s, of the fit and
    simulation alone), "terms"}, or None when SysIdentPy is in neither place."""
    try:
        from sysidentpy.model_structure_selection import FROLS  # noqa: F401
    except ImportError:
        return _narx_in_peer_env(u_est, y_est, u_test, y_test, lags, degree)
    import importlib.util
    import tempfile

    if not _peer_script().exists():
        return None
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        _write_peer_input(src, u_est, y_est, u_test, y_test, lags, degree)
        spec = importlib.util.spec_from_file_location("narx_peer", _peer_script())
        peer = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(peer)
        peer.main(str(src), str(dst))
        return _read_peer_output(dst)


def _peer_script() -> Path:
    return Path(__file__).resolve().parents[3] / "tools" / "peers" / "narx_peer.py"


def _peer_python() -> Path:
    named = os.environ.get("POROSENSE_PEER_PYTHON")
    if named:
        return Path(named)
    return Path(__file__).resolve().parents[3] / ".venv-peers" / "bin" / "python"


def _write_peer_input(path, u_est, y_est, u_test, y_test, lags, degree) -> None:
    np.savez(
        path,
        u_est=np.asarray(u_est, float).ravel(),
        y_est=np.asarray(y_est, float).ravel(),
        u_test=np.asarray(u_test, float).ravel(),
        y_test=np.asarray(y_test, float).ravel(),
        lags=lags,
        degree=degree,
    )


def _read_peer_output(path) -> dict:
    with np.load(path) as d:
        return {"yhat": d["yhat"], "wall_s": float(d["wall_s"]), "cpu_s": float(d["cpu_s"]), "terms": int(d["terms"])}


def _narx_in_peer_env(u_est, y_est, u_test, y_test, lags, degree) -> dict | None:
    import subprocess
    import tempfile

    python, script = _peer_python(), _peer_script()
    if not (python.exists() and script.exists()):
        return None
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        _write_peer_input(src, u_est, y_est, u_test, y_test, lags, degree)
        done = subprocess.run([str(python), str(script), str(src), str(dst)], capture_output=True, text=True)
        if done.returncode != 0 or not dst.exists():
            last = (done.stderr.strip().splitlines() or ["no message"])[-1]
            warnings.warn(f"SysIdentPy's NARX failed in {python}: {last}", stacklevel=2)
            return None
        return _read_peer_output(dst)


def _test_rmse(model, u, y, skip=0, periodic=False):

    if periodic:  # one steady-state period: simulate two, score the second
        n = len(y)
        return rmse(y, model.predict(u=np.vstack([u, u]))[n:])
    return rmse(y[skip:], model.predict(u=u)[skip:])


def _real_search(us, ys, vus, vys, ts, skip):
    t0, c0 = time.perf_counter(), _cpu()
    res = search(
        u=us,
        y=ys,
        ts=ts,
        validation=(vus, vys),
        validation_skip=skip,
        skip=skip,
        criterion="fit",
        staged=True,
        max_nfev=200,
        progress=False,
    )
    return res, time.perf_counter() - t0, _cpu() - c0


def _noise_level_benchmark(us, ys, ts, skip, tu, ty) -> dict:
    """WH with the process-noise level measured from the realisations' two periods (6 poles /
    3 zeros, 10 breakpoints, the default 200 evaluations) against linear 6 poles / 5 zeros."""

    t0, c0 = time.perf_counter(), _cpu()
    lin = Linear(n_poles=6, n_zeros=5, skip=skip).fit(u=us, y=ys, ts=ts)
    wh = WienerHammerstein(n_poles=6, n_zeros=3, n_breakpoints=10, skip=skip, starts=1, process_noise=True).fit(
        u=us, y=ys, ts=ts
    )
    info = wh.info.get("process_noise", {})
    return {
        "realisations": len(us),
        "wall_s": time.perf_counter() - t0,
        "cpu_s": _cpu() - c0,
        "build": wh.info.get("build"),
        "noise_level_per_spread": info.get("sigma_per_spread"),
        "period_power_ratio": info.get("power_ratio"),
        "wh_test_rmse_mV": 1e3 * _test_rmse(wh, tu, ty, skip),
        "linear_test_rmse_mV": 1e3 * _test_rmse(lin, tu, ty, skip),
    }


def real_data_benchmark() -> dict:
    """Measured benchmarks: test RMSE of the selected and of the best linear model."""

    folder = shared_data_folder()
    if folder is None:
        return {"real_data": "benchmark data folder not found"}
    out = {}
    wh = folder / "wh_process_noise"
    if wh.is_dir():
        est, test = read_table(wh / "WH_EstimationExample.csv"), read_table(wh / "WH_TestDataset.csv")
        ts, skip = 1.0 / float(est.columns["fs"][0]), 200
        us = [est.columns[f"u_{i}"][:, None] for i in range(10)]
        ys = [est.columns[f"y_{i}"] for i in range(10)]
        res, wall, cpu = _real_search(us[:8], ys[:8], us[8:], ys[8:], ts, skip)
        tu, ty = test.columns["u_0"][:, None], test.columns["y_0"]
        lin = res.best_per_structure("fit")["linear"]
        out["wh_process_noise"] = {
            "samples": int(sum(len(y) for y in ys)),
            "wall_s": wall,
            "cpu_s": cpu,
            "selected": f"{res.best.structure} {res.best.n_poles}p{res.best.n_zeros}z",
            "selected_test_rmse_mV": 1e3 * _test_rmse(res.best.model, tu, ty, skip),
            "linear_test_rmse_mV": 1e3 * _test_rmse(lin.model, tu, ty, skip),
            "per_structure_test_rmse_mV": {
                k: 1e3 * _test_rmse(c.model, tu, ty, skip) for k, c in res.best_per_structure("fit").items()
            },
            "rule": res.rule,
        }
        narx = narx_fit(np.concatenate([u[:, 0] for u in us[:8]]), np.concatenate(ys[:8]), tu[:, 0], ty)
        if narx is not None:
            out["wh_process_noise"]["narx_test_rmse_mV"] = 1e3 * float(
                np.sqrt(np.mean((ty[skip:] - narx["yhat"][skip:]) ** 2))
            )
            out["wh_process_noise"]["narx_cpu_s"] = narx["cpu_s"]
        out["wh_process_noise_level"] = _noise_level_benchmark(us[:5], ys[:5], ts, skip, tu, ty)
        out["wh_process_noise_search"] = process_noise_search(folder)
    bw = folder / "boucwen"
    if bw.is_dir():
        tr, te = read_table(bw / "train_multisine_5periods.csv"), read_table(bw / "test_multisine.csv")
        u, y, period = tr.columns["u_N"], tr.columns["y_m"], 8192
        res, wall, cpu = _real_search(
            [u[: 4 * period, None]], [y[: 4 * period]], [u[:, None]], [y], 1 / 750.0, [4 * period]
        )
        tu, ty = te.columns["u_N"][:, None], te.columns["y_m"]
        lin = res.best_per_structure("fit")["linear"]
        out["boucwen"] = {
            "samples": len(y),
            "wall_s": wall,
            "cpu_s": cpu,
            "selected": f"{res.best.structure} {res.best.n_poles}p{res.best.n_zeros}z",
            "selected_test_rmse_m": _test_rmse(res.best.model, tu, ty, periodic=True),
            "linear_test_rmse_m": _test_rmse(lin.model, tu, ty, periodic=True),
            "per_structure_test_rmse_m": {
                k: _test_rmse(c.model, tu, ty, periodic=True) for k, c in res.best_per_structure("fit").items()
            },
            "rule": res.rule,
        }
    return out


def grid_line(out: dict, size: str) -> str:
    """The paper-grid figure: wall time, CPU time of all workers and its half (2 dedicated cores)."""
    return (
        f"paper order grid: {out['grid_models']} models (4 structures, poles <= {10 if size == 'full' else 2}, "
        f"zeros < poles, 2 starts), 5 x {out['grid_seconds_each']:.0f} s at 50 Hz: {out['grid_seconds']:.1f} s wall "
        f"on {out['grid_cores']} cores at load average {out['load_average_1min']:.1f}, CPU time of all workers "
        f"{out['grid_cpu_seconds']:.1f} s (about {out['grid_cpu_seconds'] / 2:.0f} s on 2 dedicated cores; "
        f"goal <= 120 s); best {out['grid_best']} mean fit {out['grid_best_fit']:.2f} %"
    )


def process_noise_search(folder, first: int = 0, poles=(6,), max_nfev: int = 100) -> dict:
    """The search of ``identify --process-noise`` over linear and WH on 5 realisations of the
    measured WH benchmark (the next one validates), at the suite's long size: test RMSE of each
    structure's selected model on the test multisine, their ratio and the time."""
    from porosense.data import read_table
    from porosense.ident import SearchResult, rmse

    est = read_table(folder / "wh_process_noise" / "WH_EstimationExample.csv")
    test = read_table(folder / "wh_process_noise" / "WH_TestDataset.csv")
    which = list(range(first, first + 5)) + [(first + 5) % 10]
    us = [est.columns[f"u_{i}"][:, None] for i in which]
    ys = [est.columns[f"y_{i}"] for i in which]
    ts, skip = 1.0 / float(est.columns["fs"][0]), 200
    t0, c0 = time.perf_counter(), _cpu()
    res = search(
        u=us[:5],
        y=ys[:5],
        ts=ts,
        validation=(us[5:], ys[5:]),
        validation_skip=skip,
        skip=skip,
        structures=("linear", "wh"),
        poles=poles,
        max_nfev=max_nfev,
        process_noise=True,
        progress=False,
    )
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    u, y = test.columns["u_0"][:, None], test.columns["y_0"]
    err = {}
    for structure in ("linear", "wh"):
        own = SearchResult([c for c in res.candidates if c.structure == structure], 0.0, res.tie_tol, res.criterion)
        err[structure] = 1e3 * rmse(y[skip:], own.model.predict(u=u)[skip:])
    return {
        "realisations": f"{which[0]}-{which[4]}",
        "poles": list(poles),
        "max_nfev": max_nfev,
        "wall_s": wall,
        "cpu_s": cpu,
        "linear_test_rmse_mV": err["linear"],
        "wh_test_rmse_mV": err["wh"],
        "ratio": err["linear"] / err["wh"],
        "rule": res.rule,
    }


PARTS = ("oe", "grid", "scaling", "cluster", "3dof", "measured", "builds", "whsearch", "wh2009")
# Parts run only when named: research figures on the measured WH benchmark (porosense.bench.wh_noise).
ASKED_PARTS = ("builds", "whsearch")
# The small size leaves the cluster out: tests/ident/test_cluster.py checks the same model on a
# LocalCluster at a smaller cost than two cluster start-ups and three searches.
SMALL_PARTS = ("oe", "grid", "scaling")


def run(size: str = "full", only=None, wh2009=None, wh_noise=None) -> dict:
    """The benchmark parts (``only``: a subset of PARTS; default all that ``size`` runs but
    ASKED_PARTS, and wh2009 when its file is given); ``wh_noise``: the
    :class:`porosense.bench.wh_noise.Options` of builds and whsearch; figures in s, %, MB, mV
    and the data's units."""
    from porosense.errors import InputError

    default = tuple(p for p in PARTS if p not in ASKED_PARTS) if size == "full" else SMALL_PARTS
    parts = tuple(only) if only else default
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        raise InputError(f"unknown bench ident part(s) {', '.join(unknown)}; choose from {', '.join(PARTS)}")
    if wh2009 is None:
        parts = tuple(p for p in parts if p != "wh2009")
    elif "wh2009" not in parts:
        parts += ("wh2009",)
    out = {"size": size, "parts": list(parts)}
    s = []
    if "oe" in parts:
        out.update(oe_benchmark(size))
        s.append(
            f"linear OE, {out['oe_samples']:,} samples: porosense {out['oe_porosense_seconds'] * 1e3:.1f} ms, "
            f"fit {out['oe_porosense_fit']:.2f} % ({out['oe_porosense_fit_noise_free']:.2f} % of the noise-free output)"
        )
        if "oe_sippy_seconds" in out:
            s.append(
                f"SIPPY OE: {out['oe_sippy_seconds'] * 1e3:.1f} ms, fit {out['oe_sippy_fit']:.2f} %; "
                f"porosense is {out['oe_speedup']:.1f}x faster"
            )
        if "oe_narx_seconds" in out:
            s.append(
                f"SysIdentPy polynomial NARX (FROLS, {out['oe_narx_terms']} terms): "
                f"{out['oe_narx_seconds'] * 1e3:.1f} ms, fit {out['oe_narx_fit']:.2f} % "
                f"({out['oe_narx_fit_noise_free']:.2f} % noise-free); time ratio NARX / porosense "
                f"{out['oe_narx_seconds'] / out['oe_porosense_seconds']:.1f}"
            )
    if "grid" in parts:
        out.update(grid_benchmark(size))
        s.append(grid_line(out, size))
    if "scaling" in parts:
        out.update(scaling_benchmark(size))
        for r in out["scaling"]:
            s.append(
                f"default search, {r['samples']:,} samples: {r['cpu_s']:.0f} s CPU (about {r['cpu_s'] / 2:.0f} s on "
                f"2 dedicated cores), {r['wall_s']:.0f} s wall at load {r['load_average_1min']:.1f}, peak memory "
                f"{r['peak_rss_mb']:.0f} MB, {r['candidates']} candidates"
                + (" (screened, finalists refined on all samples)" if r["screening"] else "")
                + f", selected {r['selected']} (validation fit {r['validation_fit']:.2f} %)"
            )
    if "cluster" in parts:
        out.update(cluster_benchmark(size))
        c = out["cluster"]
        if isinstance(c, dict):
            for r in c["rows"]:
                who = r["workers"] if isinstance(r["workers"], str) else f"Dask LocalCluster, {r['workers']} worker(s)"
                s.append(
                    f"{c['search']}, {c['samples']:,} samples on {who}: {r['wall_s']:.0f} s wall, "
                    f"{r['cpu_s']:.0f} s CPU, same model as the local pool: {r['same_model']}"
                )
        else:
            s.append(c)
    if "3dof" in parts:
        out.update(three_dof_benchmark())
        r = out["three_dof"]
        s.append(
            f"3-DoF segment, theta_x from dR_0..2 ({r['samples']:,} samples), default search: {r['cpu_s']:.0f} s CPU "
            f"(about {r['cpu_s'] / 2:.0f} s on 2 cores; goal <= 300 s per output), {r['wall_s']:.0f} s wall at "
            f"load {r['load_average_1min']:.1f}, selected {r['selected']} ({r['validation_fit']:.2f} %)"
        )
    if "measured" in parts:
        out.update(real_data_benchmark())
        s += _measured_lines(out)
    if "builds" in parts or "whsearch" in parts:
        s += _wh_noise_parts(parts, out, wh_noise)
    if "wh2009" in parts:
        from porosense.bench import wh2009 as wh09

        out["wh2009"] = wh09.run(wh2009)
        s += wh09.summary(out["wh2009"])
    out["summary"] = s
    return out


def _wh_noise_parts(parts, out: dict, options) -> list[str]:
    """Run builds and/or whsearch into ``out``; their summary lines."""
    from porosense.bench import wh_noise

    folder = shared_data_folder()
    if folder is None or not (folder / "wh_process_noise").is_dir():
        out["wh_noise"] = "benchmark data folder not found"
        return [out["wh_noise"]]
    options = options or wh_noise.Options()
    s = []
    if "builds" in parts:
        out["wh_builds"] = wh_noise.builds(folder, options)
        s += wh_noise.builds_lines(out["wh_builds"])
    if "whsearch" in parts:
        out["wh_search"] = wh_noise.whsearch(folder, options)
        s += wh_noise.whsearch_lines(out["wh_search"])
    return s


def _measured_lines(out: dict) -> list[str]:
    s = []
    if "wh_process_noise" in out:
        r = out["wh_process_noise"]
        s.append(
            f"WH process-noise benchmark ({r['samples']} samples): selected {r['selected']} test RMSE "
            f"{r['selected_test_rmse_mV']:.2f} mV, linear {r['linear_test_rmse_mV']:.2f} mV "
            f"(ratio {r['linear_test_rmse_mV'] / r['selected_test_rmse_mV']:.2f}); {r['wall_s']:.0f} s wall, "
            f"{r['cpu_s']:.0f} s CPU"
        )
        if "narx_test_rmse_mV" in r:
            s.append(
                f"SysIdentPy polynomial NARX on the same 8 realisations: test RMSE {r['narx_test_rmse_mV']:.2f} mV "
                f"(ours / NARX {r['selected_test_rmse_mV'] / r['narx_test_rmse_mV']:.2f}), {r['narx_cpu_s']:.0f} s CPU"
            )
    if "wh_process_noise_level" in out:
        r = out["wh_process_noise_level"]
        s.append(
            f"WH process-noise benchmark, noise level from repeated periods ({r['realisations']} realisations, "
            f"WH 6p3z with process noise, linear 6p5z): WH test RMSE {r['wh_test_rmse_mV']:.2f} mV, linear "
            f"{r['linear_test_rmse_mV']:.2f} mV (ratio {r['linear_test_rmse_mV'] / r['wh_test_rmse_mV']:.2f}; "
            f"goal >= 2); level {r['noise_level_per_spread']:.2f} x g's input spread; {r['wall_s']:.0f} s wall, "
            f"{r['cpu_s']:.0f} s CPU"
        )
    if "wh_process_noise_search" in out:
        r = out["wh_process_noise_search"]
        s.append(
            f"WH process-noise search (identify --process-noise, linear and WH, 6 poles, {r['max_nfev']} "
            f"evaluations, realisations {r['realisations']}): WH {r['wh_test_rmse_mV']:.2f} mV, linear "
            f"{r['linear_test_rmse_mV']:.2f} mV, ratio {r['ratio']:.2f}; {r['cpu_s']:.0f} s CPU, {r['wall_s']:.0f} s wall"
        )
    if "boucwen" in out:
        r = out["boucwen"]
        s.append(
            f"Bouc-Wen benchmark: selected {r['selected']} test RMSE {r['selected_test_rmse_m']:.3e} m, "
            f"linear {r['linear_test_rmse_m']:.3e} m; {r['wall_s']:.0f} s wall, {r['cpu_s']:.0f} s CPU"
        )
    return s
