"""Actuator physics and the paper's experiments.

Chain per channel (one small model per stage, parameters in :mod:`porosense.sim.params`):
pneumatics -> foam mechanics (Gibson-Ashby collapse curve, creep) -> kinematics ->
piezoresistance (contact lag, pore-collapse nonlinearity, relaxation with overshoot) ->
electronics (1 kOhm divider, ADS1115) -> ground-truth sensors (markers, BNO055).

- :func:`make_plant` -- a plant stepped one sample at a time (emulator, simboard)
- :func:`schedule`, :func:`experiment_names` -- the paper's schedules as data
- :func:`run_experiment` -- a simulated experiment as a :class:`porosense.data.Recording`
- :func:`steady_state` -- stroke and sensitivity at a constant vacuum (print planning)
- :data:`EFFECT_NAMES` -- the named extra effects (off by default)
"""

from porosense.sim.effects import DEFAULTS as EFFECT_DEFAULTS
from porosense.sim.effects import EFFECT_NAMES, resolve_effects
from porosense.sim.experiment import run_experiment
from porosense.sim.params import Physics
from porosense.sim.plant import ACTUATORS, OUTPUTS, Plant, PlantReading, make_plant
from porosense.sim.schedules import LOAD_CASES_G, Schedule, experiment_names, schedule
from porosense.sim.steady import steady_state

__all__ = [
    "ACTUATORS",
    "EFFECT_DEFAULTS",
    "EFFECT_NAMES",
    "LOAD_CASES_G",
    "OUTPUTS",
    "Physics",
    "Plant",
    "PlantReading",
    "Schedule",
    "experiment_names",
    "make_plant",
    "resolve_effects",
    "run_experiment",
    "schedule",
    "steady_state",
]
