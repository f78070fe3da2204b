"""Closed-loop strain control, the host side: plant identification, PI tuning, runs and metrics.

The board runs the controller (firmware/lib/core); this package only decides its gains, sends
targets through :mod:`porosense.device` and measures what happened:

    plant      first-order-plus-dead-time model of commanded vacuum -> strain, fitted to recordings
    tuning     the lambda (IMC) PI rule and the predicted closed-loop step (python-control)
    gainsfile  the gains JSON that ``porosense control tune`` writes and ``control run`` reads
    staticmap  the steady-state strain-vs-vacuum map (the open-loop baseline users have today)
    metrics    tracking error, settling time, overshoot and steady-state error of a run
    session    run targets on a board (closed loop) or pressures (open loop) and record them
"""

from porosense.control.gainsfile import load_gains, save_gains
from porosense.control.metrics import StepMetrics, TrackingMetrics, step_metrics, tracking_metrics
from porosense.control.plant import Fopdt, fit_fopdt
from porosense.control.staticmap import StaticMap, static_map
from porosense.control.tuning import PiGains, StepPrediction, lambda_pi, predict_step

__all__ = [
    "Fopdt",
    "fit_fopdt",
    "PiGains",
    "StepPrediction",
    "lambda_pi",
    "predict_step",
    "load_gains",
    "save_gains",
    "StaticMap",
    "static_map",
    "StepMetrics",
    "TrackingMetrics",
    "step_metrics",
    "tracking_metrics",
]
