"""Simulator speed and the paper's figures it reproduces.

Speed: one contractor at 100 Hz through the paper's experiments (vectorised run) as a
multiple of real time in CPU time of this process (other load on the machine does not count;
the load average is reported beside it); the cost of one ``plant.step`` (emulator, simboard).
Figures: dR and strain at -60 kPa per porosity, the porosity power law, the release
overshoot, the rate-dependent loop areas and the load effect.
"""

from __future__ import annotations

import os
import time

import numpy as np

from porosense.sim import make_plant, pneumatics, run_experiment
from porosense.sim.analysis import fit_power_law, hold_mean, normalised_loop_area, release_overshoots


def _speed(repeats: int) -> dict:

    names = ["step_10", "step_20", "step_40", "step_60", "staircase"]
    run_experiment("contractor", "step_10")  # warm-up (imports, caches)
    simulated = cpu = wall = 0.0
    for k in range(repeats):
        for name in names:
            pneumatics.forget_runs()  # the simulation's cost, not its memo of the pressures
            t0, c0 = time.perf_counter(), time.process_time()
            rec = run_experiment("contractor", name, rate_hz=100.0, seed=k)
            cpu += time.process_time() - c0
            wall += time.perf_counter() - t0
            simulated += rec.duration + rec.ts
    plant = make_plant("contractor", seed=1)
    sp, on = np.array([-40.0, 0.0, 0.0]), np.array([True, False, False])
    n = 2000 * repeats
    c0 = time.process_time()
    for _ in range(n):
        plant.step(0.01, sp, on, on)
    step_us = (time.process_time() - c0) / n * 1e6
    plant3 = make_plant("3dof", seed=1)
    on3 = np.ones(3, dtype=bool)
    c0 = time.process_time()
    for _ in range(n):
        plant3.step(0.01, sp, on3, on3)
    step3_us = (time.process_time() - c0) / n * 1e6
    return {
        "simulated_s": simulated,
        "cpu_s": cpu,
        "wall_s": wall,
        "load_average": os.getloadavg()[0],
        "realtime_ratio": simulated / cpu,
        "step_us_contractor": step_us,
        "step_us_3dof": step3_us,
    }


def _figures() -> dict:

    porosities = [68, 76, 82, 86]
    strain, dr, strain_500 = [], [], []
    for phi in porosities:
        rec = run_experiment("contractor", "step_60", porosity=phi, seed=phi)
        loaded = run_experiment("contractor", "step_60", porosity=phi, load_g=500, seed=phi)
        strain.append(hold_mean(rec, "strain_0", -60))
        dr.append(hold_mean(rec, "dR_0", -60))
        strain_500.append(hold_mean(loaded, "strain_0", -60))
    step = run_experiment("contractor", "step_20", porosity=82, seed=1)
    stairs = run_experiment("contractor", "staircase", porosity=82, seed=2)
    step60 = run_experiment("contractor", "step_60", porosity=82, seed=3)
    cycle = (step.t >= 5.0) & (step.t < 25.0)
    shots = {
        lv: release_overshoots(run_experiment("contractor", f"step_{lv}", porosity=82, seed=lv))
        for lv in (10, 20, 40, 60)
    }
    ss_gap = {
        name: abs(hold_mean(step60, name, -60) - hold_mean(stairs, name, -60)) / np.max(np.abs(stairs[name])) * 100.0
        for name in ("strain_0", "dR_0")
    }
    return {
        "porosity": porosities,
        "strain_60_pct": strain,
        "dR_60_pct": dr,
        "strain_60_500g_pct": strain_500,
        "load_drop_pct": [a - b for a, b in zip(strain, strain_500)],
        "power_law_strain": fit_power_law(porosities, strain).to_dict(),
        "power_law_dR": fit_power_law(porosities, dr).to_dict(),
        "loop_area_step20": normalised_loop_area(step["strain_0"][cycle], step["dR_0"][cycle]),
        "loop_area_staircase": normalised_loop_area(stairs["strain_0"], stairs["dR_0"]),
        "steady_gap_pct_fs": ss_gap,
        "overshoot_pct": {lv: float(np.mean([s.peak_pct for s in v])) for lv, v in shots.items()},
        "overshoot_decayed": {lv: float(np.mean([s.decayed for s in v])) for lv, v in shots.items()},
    }


def run(size: str = "small") -> dict:
    """Speed (``realtime_ratio``, step cost in us) and the reproduced paper figures."""
    speed = _speed(1 if size == "small" else 5)
    fig = _figures()
    pl_s, pl_d = fig["power_law_strain"], fig["power_law_dR"]
    summary = [
        f"contractor at 100 Hz: {speed['realtime_ratio']:.0f}x real time in CPU time "
        f"({speed['simulated_s']:.0f} s simulated in {speed['cpu_s'] * 1e3:.0f} ms CPU, {speed['wall_s'] * 1e3:.0f} ms "
        f"wall at load average {speed['load_average']:.1f})",
        f"plant.step: {speed['step_us_contractor']:.1f} us (contractor), {speed['step_us_3dof']:.1f} us (3dof) CPU",
        "at -60 kPa, porosity "
        + ", ".join(
            f"{p}%: strain {s:.1f} %, dR {d:.1f} %"
            for p, s, d in zip(fig["porosity"], fig["strain_60_pct"], fig["dR_60_pct"])
        ),
        f"power law strain: n = {pl_s['n']:.2f}, R^2 = {pl_s['r2']:.3f}; dR: n = {pl_d['n']:.2f}, R^2 = {pl_d['r2']:.3f}",
        f"500 g load: strain drop {fig['load_drop_pct'][0]:.1f} % (68 %) vs {fig['load_drop_pct'][-1]:.1f} % (86 %)",
        f"loop area (normalised): step -20 kPa {fig['loop_area_step20']:.3f} vs staircase {fig['loop_area_staircase']:.3f}; "
        f"steady state gap at -60 kPa: strain {fig['steady_gap_pct_fs']['strain_0']:.2f} % FS, "
        f"dR {fig['steady_gap_pct_fs']['dR_0']:.2f} % FS",
        "release overshoot above R0 (mean peak, share decayed before the next pulse): "
        + ", ".join(
            f"-{lv} kPa {fig['overshoot_pct'][lv]:.2f} % ({fig['overshoot_decayed'][lv] * 100:.0f} %)"
            for lv in (10, 20, 40, 60)
        ),
    ]
    return {"size": size, **speed, **fig, "summary": summary}
