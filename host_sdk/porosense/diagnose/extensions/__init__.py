"""One handler per cause: its test (conditional on the generic linear correction) and its extension.

Each handler returns a :class:`CauseResult` with the cause's test, whether its own detector
fired (``gate``), a sentence of what it means, and the extended prediction on the
validation records (original prediction + generic correction + the cause's terms, all fitted
on the estimation records only).

The handlers live in one module per concept: :mod:`.context` (Context, CauseResult, shared
constants), :mod:`.choice` (choosing between candidate extensions), :mod:`.static` (static map),
:mod:`.play` (play operators), :mod:`.columns` (load_dependence, cross_coupling),
:mod:`.slow_regressors` (trends and the slow mode the slow causes are told apart by),
:mod:`.hysteresis`, :mod:`.slow` (slow_relaxation, time_delay), :mod:`.disturbances` (drift,
periodic_disturbance, outliers), :mod:`.saturation` and :mod:`.unmodelled`
(unmodelled_dynamics). :data:`HANDLERS` maps each cause to its handler.
"""

from __future__ import annotations

from porosense.diagnose.extensions.choice import CHOICE_FIT_SHARE, record_out_error
from porosense.diagnose.extensions.columns import SIM_LOAD_COLUMN, cross_coupling, load_dependence
from porosense.diagnose.extensions.context import (
    ADEQUATE,
    CONSTANT,
    DRIFT_TERMS,
    DYNAMICS,
    EXACT_RMS,
    FIT_RCOND,
    GENERIC,
    LAGUERRE_ORDER,
    OWN,
    POLE_GRID,
    POSTERIOR,
    CauseResult,
    Context,
)
from porosense.diagnose.extensions.context import _huber_lstsq as _huber_lstsq
from porosense.diagnose.extensions.disturbances import _state_drift_test as _state_drift_test
from porosense.diagnose.extensions.disturbances import drift, outliers, periodic_disturbance
from porosense.diagnose.extensions.hysteresis import hysteresis
from porosense.diagnose.extensions.play import PLAY_FORM_TEXT, PLAY_FORMS, PLAY_FRACTIONS
from porosense.diagnose.extensions.saturation import START_HOLD_SAMPLES, START_HOLD_SHARE, saturation
from porosense.diagnose.extensions.slow import SLOW_RIVALS, slow_relaxation, time_delay
from porosense.diagnose.extensions.slow_regressors import _slow_sets as _slow_sets
from porosense.diagnose.extensions.static import static_nonlinearity
from porosense.diagnose.extensions.unmodelled import ud_fewer_poles, unmodelled_dynamics

HANDLERS = {
    "static_nonlinearity": static_nonlinearity,
    "hysteresis": hysteresis,
    "slow_relaxation": slow_relaxation,
    "time_delay": time_delay,
    "drift": drift,
    "periodic_disturbance": periodic_disturbance,
    "load_dependence": load_dependence,
    "saturation": saturation,
    "cross_coupling": cross_coupling,
    "outliers": outliers,
    "unmodelled_dynamics": unmodelled_dynamics,
}

__all__ = [
    "LAGUERRE_ORDER",
    "FIT_RCOND",
    "GENERIC",
    "ADEQUATE",
    "CONSTANT",
    "POSTERIOR",
    "OWN",
    "DYNAMICS",
    "EXACT_RMS",
    "DRIFT_TERMS",
    "POLE_GRID",
    "CauseResult",
    "Context",
    "CHOICE_FIT_SHARE",
    "record_out_error",
    "static_nonlinearity",
    "PLAY_FRACTIONS",
    "PLAY_FORMS",
    "PLAY_FORM_TEXT",
    "hysteresis",
    "SLOW_RIVALS",
    "slow_relaxation",
    "time_delay",
    "drift",
    "periodic_disturbance",
    "SIM_LOAD_COLUMN",
    "load_dependence",
    "cross_coupling",
    "START_HOLD_SHARE",
    "START_HOLD_SAMPLES",
    "saturation",
    "outliers",
    "unmodelled_dynamics",
    "ud_fewer_poles",
    "HANDLERS",
]
