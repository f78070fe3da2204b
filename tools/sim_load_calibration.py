"""Calibration with and without the recorded load, on records the simulator did not make.

Per seed (tests/sim/load_calibration.py: tests/sim/actuator_generator.py's records of the
paper's experiments at 25 Hz, a mix made unloaded and under 500 g): the contractor simulator
calibrated with each record under its recorded load and with every record unloaded, scored on
held-out -20 / -40 kPa records unloaded and under 500 g (mean fit of dR and strain, %). One line
per seed and the mean gains. About 3 s CPU per seed.

Usage: python tools/sim_load_calibration.py [FIRST LAST]   (seeds, default 0 9)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "sim"))
import load_calibration  # noqa: E402

if __name__ == "__main__":
    first, last = (int(a) for a in sys.argv[1:3]) if len(sys.argv) >= 3 else (0, 9)
    gains = {"unloaded": [], "loaded": []}
    for seed in range(first, last + 1):
        m = load_calibration.measure(seed)
        parts = []
        for kind in ("unloaded", "loaded"):
            gains[kind].append(m["with"][kind] - m["without"][kind])
            parts.append(f"{kind} {m['without'][kind]:.2f} -> {m['with'][kind]:.2f} ({gains[kind][-1]:+.2f})")
        print(f"seed {seed}: held-out fit without -> with the load: " + ", ".join(parts), flush=True)
    for kind, g in gains.items():
        print(
            f"{kind}: mean gain {sum(g) / len(g):+.2f} fit points, least {min(g):+.2f}, positive in "
            f"{sum(x > 0 for x in g)} of {len(g)}"
        )
