"""Identification benchmark: (a) the paper's order grid, (b) linear OE against SIPPY's OE.

(a) 4 structures x poles 1..10 x zeros < poles, 2 starts per nonlinear model, on a SISO
    problem of 5 recordings x 60 s at 50 Hz (3 estimation, 2 validation) from a known
    Wiener-Hammerstein system driven by vacuum-step-like inputs; wall time on a process pool
    (each WH order runs in one task with the Wiener and Hammerstein fits it starts from).
(b) a linear output-error fit on 10,000 samples, porosense versus sippy_unipi's OE (when
    installed), wall times, their ratio and both simulation fits on the same data.
``size="small"`` runs a reduced grid (poles <= 2) on 5 x 20 s and 2,000 samples for (b).
"""

from __future__ import annotations

import os
import time
import warnings

import numpy as np
from scipy import signal

from porosense.ident import Linear, fit_percent, search
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
    t0 = time.perf_counter()
    result = search(u=[r[0] for r in est], y=[r[1] for r in est], ts=1 / FS_HZ,
                    validation=([r[0] for r in val], [r[1] for r in val]), poles=poles, starts=2, progress=False)
    seconds = time.perf_counter() - t0
    best = result.best
    per = {k: round(v.mean_fit, 3) for k, v in result.best_per_structure().items()}
    cpu = sum(c.cpu_seconds for c in result.candidates)
    return {"grid_models": len(result.candidates), "grid_seconds": seconds, "grid_cores": os.cpu_count(),
            "grid_cpu_seconds": cpu, "grid_seconds_each": seconds_each,
            "load_average_1min": os.getloadavg()[0],
            "grid_samples": int(sum(len(r[1]) for r in recs)),
            "grid_best": f"{best.structure} {best.n_poles}p{best.n_zeros}z", "grid_best_fit": best.mean_fit,
            "grid_best_fit_per_structure": per}


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
    out = {"oe_samples": n, "oe_porosense_seconds": ours_s, "oe_porosense_fit": ours_fit,
           "oe_porosense_fit_noise_free": fit_percent(y0, model.predict(u=u[:, None]))}
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
    out.update({"oe_sippy_seconds": sippy_s, "oe_sippy_fit": fit_percent(y, yhat),
                "oe_sippy_fit_noise_free": fit_percent(y0, yhat), "oe_speedup": sippy_s / ours_s})
    return out


def run(size: str = "full") -> dict:
    """Both benchmarks; figures in s and %."""
    out = {"size": size}
    out.update(oe_benchmark(size))
    out.update(grid_benchmark(size))
    s = [f"order grid: {out['grid_models']} models (4 structures, poles <= {10 if size == 'full' else 2}, "
         f"zeros < poles, 2 starts), 5 x {out['grid_seconds_each']:.0f} s at 50 Hz: {out['grid_seconds']:.1f} s "
         f"on {out['grid_cores']} cores (CPU time of the models {out['grid_cpu_seconds']:.1f} s, "
         f"load average {out['load_average_1min']:.1f}); "
         f"best {out['grid_best']} mean fit {out['grid_best_fit']:.2f} %",
         f"linear OE, {out['oe_samples']} samples: porosense {out['oe_porosense_seconds'] * 1e3:.1f} ms, "
         f"fit {out['oe_porosense_fit']:.2f} %"]
    if "oe_sippy_seconds" in out:
        s.append(f"SIPPY OE: {out['oe_sippy_seconds'] * 1e3:.1f} ms, fit {out['oe_sippy_fit']:.2f} %; "
                 f"porosense is {out['oe_speedup']:.1f}x faster")
    out["summary"] = s
    return out
