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
  ``start_s`` over ``ramp_s`` (s).
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
        Effect name to every one of its parameters.

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
        unknown = set(params) - set(DEFAULTS[name])
        if unknown:
            raise InputError(f"effect '{name}' has no parameter {sorted(unknown)} (parameters: {list(DEFAULTS[name])})")
        out[name] = {**DEFAULTS[name], **{k: float(v) for k, v in params.items()}}
    return out
