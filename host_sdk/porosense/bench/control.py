"""Closed-loop strain control under load versus the open-loop baseline (issue 17's figure).

For loads 0, 200 and 500 g on the emulator (the firmware's core over the simulated contractor):
step targets across the stroke, closed loop (the board's PI on the on-board WH estimate) and
open loop (the vacuum from the 0 g static map, what users do today). Prints the steady-state
error against the simulator's TRUE strain per load for both and their ratio; the goal is a
ratio of at most 1/3 at 500 g. Two estimators, both with gains and plant from 0 g: one
identified on 0 g recordings only, one on the paper's recordings at 0 g and under its 500 g load
(other experiments and seeds than the bench's; 200 g is a load it never saw). A load holds pore
contacts open, so a 0 g estimator under-reads the loaded strain: that floor is printed too. See
porosense.control.loadbench for the protocol.
"""

from __future__ import annotations

import time

from porosense.control.loadbench import HOLD_S, TARGETS, run_loads

GOAL_RATIO = 1.0 / 3.0


#: The loads (g) of the estimator's identification recordings, per variant.
MODEL_LOADS = {"0 g estimator": (0.0,), "0 + 500 g estimator": (0.0, 500.0)}


def _variant(name: str, size: str) -> tuple[dict, list[str]]:

    res = run_loads(size, model_loads=MODEL_LOADS[name])
    setup = res["setup"]
    lines = [
        f"  {name} (identified on {' + '.join(f'{L:g} g' for L in MODEL_LOADS[name])} recordings): WH "
        f"validation fit at 0 g {setup.model_fit:.1f} %; gains kp {setup.gains.kp_kpa:.3g} kPa/%, "
        f"ki {setup.gains.ki_kpa_per_s:.3g} kPa/(% s), slew {setup.gains.slew_per_s:g} %/s"
    ]
    loads = []
    for r in res["loads"]:
        loads.append({k: v for k, v in r.items() if k != "recordings"})
        lines.append(
            f"    {r['load_g']:>5.0f} g: closed loop {r['closed_steady_error']:.2f} %, open loop "
            f"{r['open_steady_error']:.2f} %, ratio {r['ratio']:.2f}; estimate bias "
            f"{r['estimate_bias']:+.2f} %; floor of a perfect loop on a perfect 0 g estimator "
            f"{r['floor_steady_error']:.2f} %"
        )
    r500 = next((r for r in res["loads"] if r["load_g"] == 500.0), None)
    out = {
        "model_loads_g": list(MODEL_LOADS[name]),
        "model_fit_percent": setup.model_fit,
        "plant": setup.plant.to_dict(),
        "gains": setup.gains.to_dict(),
        "static_map": setup.smap.to_dict(),
        "loads": loads,
        "ratio_500g": r500["ratio"] if r500 else None,
    }
    if r500 is not None:
        ok = r500["ratio"] <= GOAL_RATIO
        lines.append(
            f"    500 g: closed/open steady-state error ratio {r500['ratio']:.2f} "
            f"({'meets' if ok else 'misses'} the goal of <= {GOAL_RATIO:.2f})"
        )
    return out, lines


def run(size: str = "full") -> dict:

    t0 = time.perf_counter()
    lines = [
        f"control bench ({size}): targets {', '.join(f'{v:g}' for v in TARGETS[size])} % strain, "
        f"held {HOLD_S[size]:g} s each; error = true strain - target, mean |.| over the holds' last quarter; "
        "plant, gains and the open loop's static map from 0 g"
    ]
    variants = {}
    for name in MODEL_LOADS:
        variants[name], more = _variant(name, size)
        lines += more
    return {
        "size": size,
        "targets": list(TARGETS[size]),
        "hold_s": HOLD_S[size],
        "variants": variants,
        "ratio_500g": {k: v["ratio_500g"] for k, v in variants.items()},
        "goal_ratio": GOAL_RATIO,
        "wall_s": time.perf_counter() - t0,
        "summary": lines,
    }
