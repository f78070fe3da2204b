"""Calibration under the recorded load, measured on records the simulator did not make.

Records of tests/sim/actuator_generator.py (its own physics; its hanging load scales the
contraction down by 10-30 % at 500 g, lengthens the actuator by 1-5 % and raises ln R by
0.02-0.10) of the paper's experiments at 25 Hz, some made unloaded and some under the paper's
500 g (a constant hanging load, the ``load_g`` column). The contractor simulator is calibrated on
the estimation mix (staircase and -60 kPa unloaded, -10 kPa and the staircase under 500 g) twice:
with each record run under its recorded load (``porosense calibrate`` now) and with every record
run unloaded (``porosense calibrate`` before it read the load column). Each calibration is scored
on the held-out -20 / -40 kPa experiments, unloaded and under 500 g, each record replayed as
``simulate --params --replay`` replays it (under its load when the file was calibrated with
loads, unloaded otherwise): the fit of dR and of the strain (%), averaged.
"""

from __future__ import annotations

import actuator_generator
import numpy as np

from porosense.dsp.metrics import fit_percent
from porosense.sim import schedule
from porosense.sim.calibrate import ActuatorRecord, calibrate_actuator, simulate_record

RATE_HZ = 25.0
LOAD_G = 500.0  # the paper's load condition
#: (experiment, under the load?) of the estimation mix and of the held-out records
ESTIMATION = (("staircase", False), ("step_10", True), ("step_60", False), ("staircase", True))
HELD_OUT = (("step_20", False), ("step_40", False), ("step_20", True), ("step_40", True))


def records(seed: int) -> tuple[list, list]:
    """(estimation, held-out) ActuatorRecords of one seed's drawn actuator and load sensitivity."""
    rng = np.random.default_rng(seed)
    par, load_par = actuator_generator.draw(rng), actuator_generator.draw_load(rng)

    def one(name, loaded):
        s = schedule(name)
        p = s.setpoints(s.times(RATE_HZ))[:, 0]
        load = np.full(p.size, LOAD_G) if loaded else None
        r = actuator_generator.record(rng, par, p, RATE_HZ, load, load_par if loaded else None)
        label = f"{name}@{LOAD_G:g}g" if loaded else f"{name}@0g"
        return ActuatorRecord(p[:, None], 1.0 / RATE_HZ, r["dR_0"][:, None], {"strain_0": r["strain_0"]}, label, load)

    return [one(*e) for e in ESTIMATION], [one(*h) for h in HELD_OUT]


def held_out_fit(physics, held_out, use_load: bool) -> dict:
    """Record name -> mean fit (%) of dR_0 and strain_0, each record under its load if ``use_load``."""
    out = {}
    for r in held_out:
        sim = simulate_record("contractor", physics, r, load_g=r.load_g if use_load else None)
        out[r.name] = 0.5 * (fit_percent(r.dr[:, 0], sim["dR_0"]) + fit_percent(r.outputs["strain_0"], sim["strain_0"]))
    return out


def measure(seed: int) -> dict:
    """Held-out fits (%, mean over the unloaded and over the loaded records) of the simulator
    calibrated with and without the recorded load: keys ``with``/``without`` -> ``unloaded``/``loaded``."""
    est, val = records(seed)
    out = {}
    for key, use in (("with", True), ("without", False)):
        cal = calibrate_actuator("contractor", est, use_load=use)
        fits = held_out_fit(cal.physics, val, use)
        out[key] = {
            "unloaded": float(np.mean([v for r, v in zip(val, fits.values()) if r.load_g is None])),
            "loaded": float(np.mean([v for r, v in zip(val, fits.values()) if r.load_g is not None])),
        }
    return out
