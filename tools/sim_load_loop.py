"""The mission's loop for a hanging load, on records the simulator did not make.

Per seed: tests/sim/actuator_generator.py (written apart from porosense.sim and
porosense.diagnose; its load scales the contraction down, lengthens the actuator and raises
ln R) records the paper's experiments at 25 Hz; the contractor simulator is calibrated on the
unloaded estimation experiments (``porosense calibrate``), then ``porosense diagnose --sim
contractor --params P --condition load_g --save-extended FILE`` runs on the same experiments
loaded (200-500 g ramped in from 10-30 s over 5-15 s; validation: the loaded -20 / -40 kPa
experiments), and the extended file, when written, replays the loaded -40 kPa record
(``porosense simulate --params FILE --replay``). One line per seed: the top cause, the
load_dependence finding (found or not, its held-out gain and t, its test's F), the cause the file
was extended by with its held-out gain (and the factor on the measured load), the replay's dR fit
calibrated -> extended. About 2.5 s CPU per seed.

Usage: python tools/sim_load_loop.py [FIRST LAST]   (seeds, default 0 7)
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "sim"))
import actuator_generator  # noqa: E402

from porosense.cli import main  # noqa: E402
from porosense.data import Recording  # noqa: E402
from porosense.sim import schedule  # noqa: E402

RATE_HZ = 25.0
ESTIMATION = ("staircase", "step_10", "step_60")
VALIDATION = ("step_20", "step_40")


def _records(folder: Path, seed: int):
    rng = np.random.default_rng(seed)
    par, load_par = actuator_generator.draw(rng), actuator_generator.draw_load(rng)

    def one(name, loaded):
        s = schedule(name)
        p = s.setpoints(s.times(RATE_HZ))[:, 0]
        t = np.arange(p.size) / RATE_HZ
        load = np.zeros(p.size)
        if loaded:
            delta, start, ramp = rng.uniform(200.0, 500.0), rng.uniform(10.0, 30.0), rng.uniform(5.0, 15.0)
            load = delta * np.clip((t - start) / ramp, 0.0, 1.0)
        r = actuator_generator.record(rng, par, p, RATE_HZ, load if loaded else None, load_par if loaded else None)
        cols = {"p_cmd_0": p, "dR_0": r["dR_0"], "strain_0": r["strain_0"], "load_g": load}
        path = folder / f"{name}{'_loaded' if loaded else ''}.csv"
        Recording(t, cols, {}, {"p_cmd_0": "kPa", "dR_0": "%", "strain_0": "%", "load_g": "g"}).to_csv(path)
        return str(path)

    cal = [one(n, False) for n in ESTIMATION]
    return cal, [one(n, True) for n in ESTIMATION], [one(n, True) for n in VALIDATION]


def _quiet(argv) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        rc = main(argv)
    return rc, out.getvalue()


def loop(seed: int) -> str:
    """One seed's line (see the module notes)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cal, est, val = _records(folder, seed)
        params, ext = folder / "params.json", folder / "extended.json"
        _quiet(["calibrate", "contractor", "--data", *cal, "--out", str(params), "--quiet"])
        argv = ["diagnose", "--sim", "contractor", "--params", str(params), "--data", *est, "--validation-data", *val]
        argv += ["--input", "p_cmd_0", "--output", "dR_0", "--condition", "load_g", "--save-extended", str(ext)]
        _quiet(argv + ["--json-out", str(folder / "diagnosis.json")])
        doc = json.loads((folder / "diagnosis.json").read_text())
        f = next(f for f in doc["findings"] if f["cause"] == "load_dependence")
        state = (
            "found" if f["found"] else ("significant, gain not confirmed" if f["significant"] else "not significant")
        )
        stat = f["statistic"].rsplit("=", 1)[-1].strip()
        line = (
            f"seed {seed}: top {doc['top']}; load_dependence {state} "
            f"(gain {f['gain']:+.2f}, t {f['gain_t']:.2f}, F {stat})"
        )
        e = doc.get("extension")
        if not ext.exists() or e is None:
            return line + "; no file written"
        line += f"; extended by {e['cause']} (held-out gain {e['gain']:+.2f}"
        if e["cause"] == "load_dependence":
            line += f", factor {e['fitted']['factor']:.3g}, {e['gain_unit_factor']:+.2f} with factor 1"
        fits = []
        for name, path in (("calibrated", params), ("extended", ext)):
            out = folder / f"{name}_replay.csv"
            _, text = _quiet(
                ["simulate", "contractor", "--params", str(path), "--replay", val[1], "--out", str(out)] + ["--json"]
            )
            fits.append(json.loads(text)["fits"]["dR_sim_0"])
        return line + f"); replay of loaded step_40: dR fit {fits[0]:.2f} -> {fits[1]:.2f} %"


if __name__ == "__main__":
    first, last = (int(a) for a in sys.argv[1:3]) if len(sys.argv) >= 3 else (0, 7)
    for s in range(first, last + 1):
        print(loop(s), flush=True)
