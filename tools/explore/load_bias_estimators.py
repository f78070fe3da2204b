"""How a hanging load biases the strain estimate, per estimator input set (simulated contractor).

Three Hammerstein estimators (2 poles, 1 zero, 6 breakpoints) are identified on simulated
recordings and scored on staircases at 0, 200 and 500 g (seeds they never saw):
dR alone identified at 0 g; dR alone identified across 0/200/500 g; dR and the commanded vacuum
identified across the same loads. Prints the RMS and mean (bias) of estimate - true strain
(% strain) per load. Run: .venv/bin/python tools/explore/load_bias_estimators.py
"""

import numpy as np

from porosense import ident
from porosense.sim.experiment import run_experiment

RATE_HZ = 50
SKIP = 200  # samples left out of the scores: the start from rest


def record(experiment: str, load_g: float, seed: int):
    """(inputs: dR/100 and commanded vacuum/100, true strain %) of one simulated recording."""
    c = run_experiment("contractor", experiment, load_g=load_g, rate_hz=RATE_HZ, seed=seed).columns
    return np.c_[c["dR_0"] / 100, c["p_cmd_0"] / 100], c["strain_0"]


def fit(data, columns):
    u = [d[0][:, columns] for d in data]
    return ident.Hammerstein(n_poles=2, n_zeros=1, n_breakpoints=6).fit(u=u, y=[d[1] for d in data], ts=1 / RATE_HZ)


def main() -> None:
    loaded = [
        record(e, L, s)
        for s, (e, L) in enumerate(
            [
                ("staircase", 0),
                ("step_40", 0),
                ("staircase", 200),
                ("step_60", 200),
                ("staircase", 500),
                ("step_20", 500),
            ]
        )
    ]
    unloaded = [record(e, 0, 10 + s) for s, e in enumerate(["staircase", "step_40", "step_60", "step_20"])]
    tests = {L: record("staircase", L, 100 + L) for L in (0, 200, 500)}
    estimators = {
        "dR, identified at 0 g": (unloaded, [0]),
        "dR, identified at 0/200/500 g": (loaded, [0]),
        "dR + p_cmd, identified at 0/200/500 g": (loaded, [0, 1]),
    }
    for name, (data, columns) in estimators.items():
        model = fit(data, columns)
        cells = []
        for L, (u, y) in tests.items():
            e = (model.predict(u=u[:, columns]) - y)[SKIP:]
            cells.append(f"{L} g: RMS {np.sqrt(np.mean(e**2)):.2f}, mean {np.mean(e):+.2f}")
        print(f"{name:40s}" + " | ".join(cells))


if __name__ == "__main__":
    main()
