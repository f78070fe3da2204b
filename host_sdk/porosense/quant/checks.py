"""Checks that keep a model that could hurt the board from becoming a blob.

A model reaches the board's estimator (and, under strain control, its pumps) through
``quantize`` and ``flash``. These checks refuse (ModelError, exit 4; ``--force`` on the command
line turns them into warnings) what the board would run badly:

- a coefficient that is not a number (NaN, inf), named as such;
- a table (f, g) whose breakpoints do not strictly increase;
- a linear block (H1, H2) with a pole on or outside the unit circle (|z| >= 1): its output
  grows without bound or never settles;
- a fixed-point estimate that saturates, or that differs from the float model by more than
  :data:`MIN_FIXED_VS_FLOAT_FIT`, on the given recordings or, without recordings, on a probe of
  steps across the model's own input range;
- a model whose float output fits a given recording's measured output below
  :data:`MIN_FIT_VS_DATA` (worse than predicting the recording's mean: not a model of it,
  e.g. a file whose parameters were scrambled).

An unstable block cannot be forced: the board refuses such a blob (est::blob::section_stable).
"""

from __future__ import annotations

import math

import numpy as np

from porosense.errors import ModelError

#: NRMSE fit (%) the fixed-point estimate must reach against the float model on the same inputs:
#: its error at most 5 % of the output's variation, a third of the models' own error (the
#: paper's WH models fit 83-85 %: 15-17 %). The quantizer's random and paper-set models reach
#: 97.8-100 % on full-range probes (tests/quant), so the bound refuses only a broken scaling.
MIN_FIXED_VS_FLOAT_FIT = 95.0
#: NRMSE fit (%) below which the float model is not a model of a recording: 0 % is what the
#: recording's own mean achieves.
MIN_FIT_VS_DATA = 0.0
PROBE_SAMPLES = 2000
PROBE_SEED = 34


def _finite(name: str, values) -> None:
    v = np.asarray(values, dtype=float)
    if np.isnan(v).any():
        raise ModelError(f"{name} holds NaN (not a number)")
    if np.isinf(v).any():
        raise ModelError(f"{name} holds an infinite value (inf)")


def max_pole_radius(sos) -> float:
    """The largest pole magnitude of a cascade of second-order sections (rows b0 b1 b2 a0 a1 a2)."""
    radius = 0.0
    for row in np.atleast_2d(np.asarray(sos, dtype=float)):
        a = row[3:6] / row[3]
        if np.any(a[1:] != 0):
            radius = max(radius, float(np.max(np.abs(np.roots(np.trim_zeros(a, "b"))))))
    return float(radius)


def check_structure(structure) -> None:
    """Refuse (ModelError) a float estimator structure with a non-finite coefficient, a table
    whose breakpoints do not strictly increase, or an unstable H1/H2 block."""
    for out in structure.outputs:
        blocks = [(f"{out.name}: H1 of input {structure.inputs[b.input]}", b.h1, b.f) for b in out.branches]
        for where, h1, f in blocks:
            _finite(where, h1.sos)
            if f is not None:
                _table(f"{where.replace('H1', 'f')}", f)
        if out.g is not None:
            _table(f"{out.name}: g", out.g)
        if out.h2 is not None:
            _finite(f"{out.name}: H2", out.h2.sos)
            blocks.append((f"{out.name}: H2", out.h2, None))
        _finite(f"{out.name}: offset", [out.offset])
        for where, h, _ in blocks:
            r = max_pole_radius(h.sos)
            if r >= 1.0:
                raise ModelError(
                    f"{where} has a pole at |z| = {r:.6g}, on or outside the unit circle: the model is "
                    "unstable (its estimate would grow without bound on the board)"
                )


def _table(where: str, table) -> None:
    _finite(f"{where} breakpoints", table.x)
    _finite(f"{where} values", table.y)
    x = np.asarray(table.x, dtype=float)
    if np.any(np.diff(x) <= 0):
        k = int(np.flatnonzero(np.diff(x) <= 0)[0])
        raise ModelError(f"{where} breakpoints do not strictly increase ({x[k]:.6g} then {x[k + 1]:.6g})")


def probe_inputs(ranges, n: int = PROBE_SAMPLES, seed: int = PROBE_SEED) -> np.ndarray:
    """Held random steps spanning each input's range (structure units), shape (n, n_inputs):
    a probe for a model that comes without recordings."""
    rng = np.random.default_rng(seed)
    cols = []
    for lo, hi in ranges:
        levels = rng.uniform(lo, hi, n // 50 + 2)
        levels[:2] = lo, hi  # both ends of the range, held
        cols.append(np.repeat(levels, 50)[:n])
    return np.column_stack(cols)


def check_fits(report) -> None:
    """Refuse a quantization whose fixed-point estimate saturates or misses the float model
    (:data:`MIN_FIXED_VS_FLOAT_FIT`) on any recording of the report."""
    for fit in report.fits:
        d = fit.fit_float_vs_data
        if d is not None and not math.isfinite(d):
            raise ModelError(
                f"the model's fit on {fit.recording} (output {fit.output}) is not a number: the recording's "
                "output is constant (nothing to score against) or the model's output is not finite"
            )
        if d is not None and d < MIN_FIT_VS_DATA:
            shown = f"{d:.4g} %"
            raise ModelError(
                f"the model's fit on {fit.recording} (output {fit.output}) is {shown}, below {MIN_FIT_VS_DATA:g} % "
                "(the recording's mean): it is not a model of this data"
            )
        if fit.saturated_samples:
            raise ModelError(
                f"the fixed-point estimate saturates on {fit.recording} ({fit.saturated_samples} samples, output "
                f"{fit.output}): the board's estimate would stick at its limit"
            )
        f = fit.fit_fixed_vs_float
        if f is None or not math.isfinite(f) or f < MIN_FIXED_VS_FLOAT_FIT:
            shown = "not a number" if f is None or not math.isfinite(f) else f"{f:.2f} %"
            raise ModelError(
                f"the fixed-point estimate differs from the float model on {fit.recording} (output {fit.output}): "
                f"fit {shown}, below {MIN_FIXED_VS_FLOAT_FIT:g} %"
            )
