"""Identification benchmark: (a) the paper's order grid, (b) linear OE against SIPPY's OE.

(a) 4 structures x poles 1..10 x zeros < poles, 2 starts per nonlinear model, on a SISO
    problem of 5 recordings x 60 s at 50 Hz (3 estimation, 2 validation) from a known
    Wiener-Hammerstein system driven by vacuum-step-like inputs; wall time on a process pool
    (each WH order runs in one task with the Wiener and Hammerstein fits it starts from).
(b) a linear output-error fit on 10,000 samples, porosense versus sippy_unipi's OE (when
    installed), wall times, their ratio and both simulation fits on the same data.
(c) the default (staged) search against the number of samples (10k, 30k, 100k) on the
    system of (a), so that the growth of the cost is visible.
(d) measured data (when the benchmark folder is present): the Wiener-Hammerstein benchmark with
    process noise (estimate on 8 realisations of WH_EstimationExample, select on the other 2,
    test on the WH_TestDataset multisine) and the Bouc-Wen benchmark (estimate on periods 1-4
    of the 5-period multisine, select on period 5, test on the official multisine); test RMSE
    of the selected model and of the best linear model; and the same WH benchmark with the
    process-noise level measured from the two periods of 5 realisations (fixed orders).
``size="small"`` runs a reduced grid (poles <= 2) on 5 x 20 s, 2,000 samples for (b), 2k/5k
samples for (c) and skips (d).

Times: wall time, and CPU time summed over this process and its worker processes
(resource.getrusage); on a shared machine the CPU time is the figure to compare with a bound
"on 2 cores" (CPU / 2), the wall time depends on the load (printed).
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


def scaling_benchmark(size: str) -> dict:
    """Default staged search (4 structures, poles <= 10) time against the number of samples."""
    counts = (10_000, 30_000, 100_000) if size == "full" else (2_000, 5_000)
    rows = []
    for n in counts:
        recs = [step_recording(seed, n / 4 / FS_HZ) for seed in range(4)]
        t0, c0 = time.perf_counter(), _cpu()
        res = search(
            u=[r[0] for r in recs[:3]],
            y=[r[1] for r in recs[:3]],
            ts=1 / FS_HZ,
            validation=([recs[3][0]], [recs[3][1]]),
            criterion="fit",
            staged=True,
            max_nfev=200,
            progress=False,
        )
        rows.append(
            {
                "samples": n,
                "wall_s": time.perf_counter() - t0,
                "cpu_s": _cpu() - c0,
                "selected": f"{res.best.structure} {res.best.n_poles}p{res.best.n_zeros}z",
                "validation_fit": res.best.validation_fit,
            }
        )
    return {"scaling": rows}


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
        out["wh_process_noise_level"] = _noise_level_benchmark(us[:5], ys[:5], ts, skip, tu, ty)
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


def run(size: str = "full") -> dict:
    """All benchmarks; figures in s, % and the data's units."""
    out = {"size": size}
    out.update(oe_benchmark(size))
    out.update(grid_benchmark(size))
    out.update(scaling_benchmark(size))
    if size == "full":
        out.update(real_data_benchmark())
    s = [
        f"linear OE, {out['oe_samples']} samples: porosense {out['oe_porosense_seconds'] * 1e3:.1f} ms, "
        f"fit {out['oe_porosense_fit']:.2f} %"
    ]
    for r in out["scaling"]:
        s.append(
            f"default staged search, {r['samples']:,} samples: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU "
            f"(about {r['cpu_s'] / 2:.0f} s on 2 dedicated cores; goal at 100,000: <= 300 s), "
            f"selected {r['selected']}"
        )
    s.append(grid_line(out, size))
    if "wh_process_noise" in out:
        r = out["wh_process_noise"]
        s.append(
            f"WH process-noise benchmark ({r['samples']} samples): selected {r['selected']} test RMSE "
            f"{r['selected_test_rmse_mV']:.2f} mV, linear {r['linear_test_rmse_mV']:.2f} mV "
            f"(ratio {r['linear_test_rmse_mV'] / r['selected_test_rmse_mV']:.2f}); {r['wall_s']:.0f} s wall, "
            f"{r['cpu_s']:.0f} s CPU"
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
    if "boucwen" in out:
        r = out["boucwen"]
        s.append(
            f"Bouc-Wen benchmark: selected {r['selected']} test RMSE {r['selected_test_rmse_m']:.3e} m, "
            f"linear {r['linear_test_rmse_m']:.3e} m; {r['wall_s']:.0f} s wall, {r['cpu_s']:.0f} s CPU"
        )
    if "oe_sippy_seconds" in out:
        s.append(
            f"SIPPY OE: {out['oe_sippy_seconds'] * 1e3:.1f} ms, fit {out['oe_sippy_fit']:.2f} %; "
            f"porosense is {out['oe_speedup']:.1f}x faster"
        )
    out["summary"] = s
    return out
