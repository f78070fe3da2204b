"""Named extra effects, off by default; the names are the diagnosis causes.

Each effect has parameters with units (defaults below). Pass them to ``make_plant`` or
``run_experiment`` as a list of names (default parameters) or a dict
``{name: {param: value}}`` (missing parameters take their defaults).

- ``drift``: slow baseline change of the sensor resistance, ``rate_pct_per_min`` (% of R0
  per minute).
- ``time_delay``: the resistance reading lags the physics by ``delay_s`` (s).
- ``periodic_disturbance``: a sinusoid on dR, ``amplitude_pct`` (dR %) at ``freq_hz`` (Hz)
  and ``phase_deg`` (deg) on the plant clock; e.g. pump vibration, or 50 Hz mains hum aliased
  by the sample rate (at exactly fs/2 choose a phase other than 0 to see it).
- ``saturation``: the ADC input clips to ``[low_V, high_V]`` (V) (divider or PGA range).
- ``load_dependence``: the load changes by ``delta_g`` (g) during a record, ramping from
  ``start_s`` over ``ramp_s`` (s). Its measured form ``{"column": COL, "unit": "g", "factor":
  k}`` (what ``diagnose --sim ... --save-extended`` writes, :data:`MEASURED`) takes the load
  during a record from the recording's column COL (g) instead, times ``factor`` (1: as
  measured): it runs on a recording only (porosense.sim.calibrate.simulate_record, ``simulate
  --replay``), and a plant without one refuses it.
- ``slow_relaxation``: an extra slow relaxation mode of the resistance, ``tau_s`` (s) and
  ``gain`` (fraction of the change in dR).
- ``cross_coupling``: 3-DoF channels leak into each other's contact strain, ``gain``
  (fraction of the neighbours' strain); no effect on one-channel actuators.
- ``outliers``: glitches of ``glitch_pct`` (dR %) with probability ``glitch_prob`` per sample,
  and dropped samples with probability ``drop_prob`` (missing rows in a recording, a stale
  reading from the plant).
"""

from __future__ import annotations

from porosense.errors import InputError

DEFAULTS: dict[str, dict[str, float]] = {
    "drift": {"rate_pct_per_min": 1.5},
    "time_delay": {"delay_s": 0.25},
    "periodic_disturbance": {"amplitude_pct": 1.5, "freq_hz": 7.3, "phase_deg": 0.0},
    "saturation": {"low_V": 1.2, "high_V": 4.096},
    "load_dependence": {"delta_g": 400.0, "start_s": 20.0, "ramp_s": 10.0},
    "slow_relaxation": {"tau_s": 25.0, "gain": 0.12},
    "cross_coupling": {"gain": 0.25},
    "outliers": {"glitch_pct": 15.0, "glitch_prob": 0.004, "drop_prob": 0.003},
}

EFFECT_NAMES = tuple(DEFAULTS)

#: effects that take a condition from the recording: the measured form's parameters and defaults
#: (``column``: the recording's column, ``unit``: its unit, ``factor``: the simulated load per
#: measured load, 1)
MEASURED: dict[str, dict] = {"load_dependence": {"column": "load_g", "unit": "g", "factor": 1.0}}


def measured_load(effects) -> tuple[str, float] | None:
    """(column, factor) of a resolved ``load_dependence`` in its measured form, else None."""
    eff = (effects or {}).get("load_dependence") if isinstance(effects, dict) else None
    if eff and "column" in eff:
        return str(eff["column"]), float(eff["factor"])
    return None


def _measured(name: str, params: dict) -> dict:
    known = MEASURED[name]
    unknown = set(params) - set(known)
    if unknown:
        raise InputError(
            f"effect '{name}' from a column has no parameter {sorted(unknown)} (parameters: {list(known)})"
        )
    out = {**known, **params}
    column, unit = out["column"], str(out["unit"]).strip()
    if not isinstance(column, str) or not column.strip():
        raise InputError(f"effect '{name}': 'column' must name the recording's column, got {column!r}")
    if unit != known["unit"]:
        raise InputError(f"effect '{name}': the column's unit must be {known['unit']}, got {unit!r}")
    try:
        factor = float(out["factor"])
    except (TypeError, ValueError):
        factor = float("nan")
    if not (factor >= 0.0 and factor < float("inf")):
        raise InputError(f"effect '{name}': 'factor' must be a finite number >= 0, got {out['factor']!r}")
    return {"column": column.strip(), "unit": unit, "factor": factor}


def resolve_effects(effects) -> dict[str, dict[str, float]]:
    """Normalise named extra effects to their full parameters.

    Parameters
    ----------
    effects : None, str, sequence of str or dict
        None (no effect), one name, names (default parameters), or ``{name: {param: value}}``
        (missing parameters take their defaults; units in the module notes).

    Returns
    -------
    dict of str to dict of str to float
        Effect name to every one of its parameters (a :data:`MEASURED` form keeps its column name
        and unit as strings).

    Raises
    ------
    InputError
        An unknown effect or parameter.
    """
    if effects is None:
        return {}
    if isinstance(effects, str):
        effects = [effects]
    if not isinstance(effects, dict):
        effects = {name: {} for name in effects}
    out = {}
    for name, params in effects.items():
        if name not in DEFAULTS:
            raise InputError(f"unknown effect '{name}' (known: {', '.join(EFFECT_NAMES)})")
        params = dict(params or {})
        if name in MEASURED and "column" in params:
            out[name] = _measured(name, params)
            continue
        unknown = set(params) - set(DEFAULTS[name])
        if unknown:
            raise InputError(f"effect '{name}' has no parameter {sorted(unknown)} (parameters: {list(DEFAULTS[name])})")
        out[name] = {**DEFAULTS[name], **{k: float(v) for k, v in params.items()}}
    return out
