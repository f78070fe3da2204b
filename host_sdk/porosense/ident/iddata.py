"""MATLAB-style estimation commands on a :class:`porosense.data.Dataset`: fit, predict, compare, resid.

    data = porosense.Dataset.from_file("run.csv", inputs=["dR_0"], outputs=["strain_0"])
    model = porosense.fit("wh", data, n_poles=4, n_zeros=2)        # nlhw / tfest
    yhat = porosense.predict(model, data)                           # sim
    porosense.compare(model, data)                                  # compare: the one fit
    porosense.resid(model, data).plot()                             # resid

The period is the data's (``Dataset.ts_s``); a model meets data only at its own period (within 1 %).
"""

from __future__ import annotations

import numpy as np

from porosense.errors import InputError
from porosense.ident.residuals import LAGS, ResidResult, residual_tests
from porosense.ident.scoring import SimulationFit, model_outputs, simulation_fit

PERIOD_TOLERANCE = 0.01


def _check_period(model, data) -> None:
    ts = data.ts_s
    if abs(ts - model.ts) > PERIOD_TOLERANCE * model.ts:
        raise InputError(
            f"the data's sample period {ts * 1000:.4g} ms ({1 / ts:.4g} Hz) differs from the model's "
            f"{model.ts * 1000:.4g} ms ({1 / model.ts:.4g} Hz): a model runs per sample"
        )


def _inputs(model, data) -> np.ndarray:
    if data.u.shape[1] != len(model.inputs):
        raise InputError(f"the data have {data.u.shape[1]} inputs, the model {len(model.inputs)} ({model.inputs})")
    return data.u


def _outputs(model, data) -> np.ndarray:
    if data.y is None:
        raise InputError("the data hold no outputs to compare with")
    names = model_outputs(model)
    if data.y.shape[1] != len(names):
        raise InputError(f"the data have {data.y.shape[1]} outputs, the model {len(names)} ({names})")
    return data.y


def fit(kind, data, *, n_poles: int, n_zeros: int = 0, **options):
    """Estimate a model of structure ``kind`` (linear, hammerstein, wiener, wh) on ``data``.

    Parameters
    ----------
    kind : str
        The structure.
    data : Dataset
        Inputs and outputs (every output gets its own model; several make a ModelSet).
    n_poles, n_zeros : int
        The order.
    **options
        Passed to the model's constructor (``n_breakpoints``, ``starts``, ...).

    Returns
    -------
    Model or ModelSet
        Fitted on ``data`` at its period (s), with its names and units.
    """
    from porosense.ident.models import ModelSet, make_model
    from porosense.structure import INPUT_UNITS

    y = _outputs_present(data)
    # dR inputs carry a unit the quantizer scales from ("%" or "dR/100"); other units stay with the data.
    units = data.input_units if all(u in INPUT_UNITS for u in data.input_units) else None
    models = []
    for j, name in enumerate(data.output_names):
        m = make_model(kind, n_poles=n_poles, n_zeros=n_zeros, **options)
        m.fit(
            u=data.u,
            y=y[:, j],
            ts=data.ts_s,
            inputs=tuple(data.input_names),
            output=name,
            input_unit=units,
            output_unit=data.output_units[j] or None,
        )
        models.append(m)
    return models[0] if len(models) == 1 else ModelSet(models)


def _outputs_present(data) -> np.ndarray:
    if data.y is None:
        raise InputError("the data hold no outputs to fit")
    return data.y


def predict(model, data) -> np.ndarray:
    """The model simulated from rest on ``data``'s inputs (MATLAB's sim).

    Parameters
    ----------
    model : Model or ModelSet
        An identified model (``porosense.fit``, ``load_model``).
    data : Dataset
        Inputs at the model's sample period (within 1 %), in the model's input units.

    Returns
    -------
    ndarray, shape (N, n_outputs)
        Simulated outputs, in the model's output units.

    Raises
    ------
    InputError
        A sample period or a number of inputs that differs from the model's.
    """
    _check_period(model, data)
    y = np.asarray(model.predict(u=_inputs(model, data)), float)
    return y[:, None] if y.ndim == 1 else y


def compare(model, data) -> SimulationFit:
    """The one fit of ``model`` simulated from rest on ``data`` (MATLAB's compare).

    Parameters
    ----------
    model : Model or ModelSet
        An identified model.
    data : Dataset
        Inputs and measured outputs at the model's sample period (within 1 %).

    Returns
    -------
    SimulationFit
        Per output, NRMSE fit (%) and RMS error (% of max |y|).

    Raises
    ------
    InputError
        A sample period, number of inputs or number of outputs that differs from the model's, or
        data without outputs.
    """
    _check_period(model, data)
    return simulation_fit(model, _inputs(model, data), _outputs(model, data))


def resid(model, data, lags: int = LAGS) -> ResidResult:
    """Residual correlation tests of ``model`` on ``data`` (MATLAB's resid).

    Parameters
    ----------
    model : Model or ModelSet
        An identified model.
    data : Dataset
        Inputs and measured outputs at the model's sample period (within 1 %).
    lags : int
        Largest lag of the auto- and cross-correlations, samples.

    Returns
    -------
    ResidResult
        Whiteness of the residuals and their independence from the inputs, with 99 % bounds
        (see :mod:`porosense.ident.residuals`); ``.plot()`` draws them.

    Raises
    ------
    InputError
        As :func:`compare`.
    """
    _check_period(model, data)
    y = _outputs(model, data)
    e = y - predict(model, data)
    return residual_tests(data.u, e, inputs=data.input_names, outputs=model_outputs(model), lags=lags)
