"""The one fit of a model on data that every command prints (docs/cli.md, "Fit: one number").

``simulation_fit(model, u, y)`` simulates the model from rest (zero initial state, as the board's
estimator runs after a reset and as identification fits and scores) over the whole record and
scores every sample: NRMSE fit (MATLAB ``compare`` with ``InitialCondition`` 'z') and RMS in %
of the largest |output|. predict, compare, report, verify and diagnose call it, so the same model
on the same data gives the same number everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from porosense.errors import InputError, ModelError
from porosense.ident.metrics import fit_percent, rms_percent

INITIAL_CONDITION = "rest"  # zero initial state; stated wherever a fit is printed


def format_percent(value: float, digits: int = 2) -> str:
    """A percentage as text.

    Parameters
    ----------
    value : float or None
        The value, %.
    digits : int
        Decimals.

    Returns
    -------
    str
        ``"84.46 %"``; ``"n/a"`` when None or not finite.
    """
    return f"{value:.{digits}f} %" if value is not None and math.isfinite(value) else "n/a"


@dataclass
class SimulationFit:
    """Fit and RMS per output of a model simulated from rest on one record.

    Attributes
    ----------
    outputs : list of str
        Output names.
    fit : dict of str to float
        Output name to NRMSE fit, % (NaN when the measured output is constant: printed 'n/a').
    rms : dict of str to float
        Output name to RMS error, % of max |y|.
    samples : int
        Samples scored.
    yhat : ndarray, shape (N, n_outputs)
        The simulated output, in each output's unit.
    initial : str
        The initial condition, ``"rest"`` (zero state).
    """

    outputs: list[str]
    fit: dict[str, float]
    rms: dict[str, float]
    samples: int
    yhat: np.ndarray | None = field(repr=False, default=None)
    initial: str = INITIAL_CONDITION

    def line(self, name: str) -> str:
        """One output's fit in words.

        Parameters
        ----------
        name : str
            Output name.

        Returns
        -------
        str
            E.g. ``"strain_0: fit 84.46 %, RMS 3.21 % of max |strain_0|"``.
        """
        return f"{name}: fit {format_percent(self.fit[name])}, RMS {format_percent(self.rms[name])} of max |{name}|"

    def __str__(self) -> str:
        return "\n".join(self.line(o) for o in self.outputs)

    def to_dict(self) -> dict:
        """The figures as a plain dict (without the simulated output).

        Returns
        -------
        dict
            ``outputs``, ``fit`` (%), ``rms`` (% of max |y|), ``samples``, ``initial``.
        """
        return {
            "outputs": list(self.outputs),
            "fit": dict(self.fit),
            "rms": dict(self.rms),
            "samples": self.samples,
            "initial": self.initial,
        }


def simulation_fit(model, u, y, *, outputs=None, expected: bool = False) -> SimulationFit:
    """Simulate ``model`` from rest on ``u`` and score it against the measured ``y``.

    Parameters
    ----------
    model
        An identified model (``Model``, ``ModelSet`` or an extended model): anything with
        ``predict(u=...)``.
    u : array_like, (N,) or (N, n_inputs)
        Inputs in the model's input order and units.
    y : array_like, (N,) or (N, n_outputs)
        Measured outputs in the model's output order and units.
    outputs : list of str, optional
        Output names (default: the model's).
    expected : bool
        For a model with process noise: score its output averaged over the noise.

    Returns
    -------
    SimulationFit
        Fit and RMS in % per output, the simulated output and the sample count.

    Raises
    ------
    InputError
        When ``u`` and ``y`` differ in length or hold non-finite values.
    ModelError
        When the simulation diverges (non-finite output).
    """
    x = np.asarray(u, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    meas = np.asarray(y, dtype=float)
    meas = meas[:, None] if meas.ndim == 1 else meas
    if x.shape[0] != meas.shape[0]:
        raise InputError(f"inputs have {x.shape[0]} samples, outputs {meas.shape[0]}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(meas))):
        raise InputError("inputs or outputs hold empty or non-finite values")
    names = list(outputs) if outputs is not None else model_outputs(model)
    if meas.shape[1] != len(names):
        raise InputError(f"{meas.shape[1]} output columns for the model's {len(names)} outputs ({', '.join(names)})")
    with np.errstate(all="ignore"):
        yhat = model.predict(u=x, expected=True) if expected else model.predict(u=x)
    yhat = np.asarray(yhat, dtype=float)
    yhat = yhat[:, None] if yhat.ndim == 1 else yhat
    if not np.all(np.isfinite(yhat)):
        raise ModelError(f"the simulation diverges ({int(np.sum(~np.isfinite(yhat)))} non-finite values)")
    return score_simulation(yhat, meas, names)


def score_simulation(yhat, y, outputs) -> SimulationFit:
    """Score outputs already simulated from rest (``yhat``, (N, k)) against ``y`` (N, k).

    For callers that simulate once and score a subset of the outputs (predict); everyone else
    calls :func:`simulation_fit`.
    """
    yhat = np.asarray(yhat, dtype=float).reshape(len(yhat), -1)
    meas = np.asarray(y, dtype=float).reshape(len(y), -1)
    names = list(outputs)
    fit = {o: fit_percent(meas[:, j], yhat[:, j]) for j, o in enumerate(names)}
    rms = {o: rms_percent(meas[:, j], yhat[:, j]) for j, o in enumerate(names)}
    return SimulationFit(names, fit, rms, int(meas.shape[0]), yhat)


def model_outputs(model) -> list[str]:
    """The output names of a model or model set."""
    return [model.output] if hasattr(model, "output") else list(model.outputs)
