"""Diagnosis benchmark: hidden-effect trials, top-1 rate per cause and the false-alarm rate.

Two sets: the contractor-like surrogate with every cause (porosense.diagnose.trials.run_trial,
a first-order OE baseline) and the actuator simulator with its named effects against the
calibrated simulator (run_sim_trial, the ``--sim`` path; cross_coupling in the 3-DoF segment).
small: 3 trials per cause (CI); full: 20 trials per cause (the issue's figure). Seeds 1000,
1001, ... as in tests/diagnose.
"""

from __future__ import annotations

import time

from porosense.diagnose import trials
from porosense.diagnose.catalogue import NONE


def run(size: str) -> dict:
    n = 3 if size == "small" else 20
    t0 = time.perf_counter()
    res = trials.run_trials(n, seed=1000)
    causes = [c for c in res if c != NONE]
    out = {
        "trials_per_cause": n,
        "top1_rate": {c: res[c]["top1_rate"] for c in causes},
        "positive_gain_rate": {c: res[c]["positive_gain_rate"] for c in causes},
        "mean_gain_points": {c: round(res[c]["mean_gain"], 2) for c in causes},
        "false_alarm_rate": 1.0 - res[NONE]["top1_rate"],
        "seconds_per_trial": round((time.perf_counter() - t0) / (n * len(res)), 3),
    }
    sim_rate, sim_gain = {}, {}
    for cause in list(trials.SIM_CAUSES) + [NONE]:
        runs = [trials.run_sim_trial(cause, 1000 + k) for k in range(n)]
        sim_rate[cause] = sum(r.top == cause for r in runs) / n
        sim_gain[cause] = sum(r.gain > 0 for r in runs if r.top == cause) / max(sum(r.top == cause for r in runs), 1)
    out["sim_top1_rate"] = sim_rate
    out["sim_positive_gain_rate"] = {c: g for c, g in sim_gain.items() if c != NONE}
    out["summary"] = [
        f"{c:<21} top-1 {100 * out['top1_rate'][c]:5.1f} %  positive gain {100 * out['positive_gain_rate'][c]:5.1f} %"
        f"  mean gain {out['mean_gain_points'][c]:+.2f} fit points" for c in causes
    ] + [f"clean data: top is not none in {100 * out['false_alarm_rate']:.1f} % of {n} trials",
         f"{out['seconds_per_trial']} s per surrogate trial ({n} trials per cause)"] + [
        f"simulator {c:<21} top-1 {100 * r:5.1f} %"
        + (f"  positive gain {100 * sim_gain[c]:5.1f} %" if c != NONE else "") for c, r in sim_rate.items()]
    return out
