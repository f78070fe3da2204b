"""Rate-independent memory: the play operators (Prandtl-Ishlinskii) in their nested forms
(:data:`PLAY_FORMS`), the regressors the hysteresis test tests and the slow causes are told apart from.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose.extensions.context import Context
from porosense.dsp import play_operator

#: radii of the play operators: a generic half-decade grid, fractions of each signal's span
PLAY_FRACTIONS = (0.01, 0.03, 0.1, 0.3)


#: the forms of rate-independent memory, nested from the fewest regressors to the most: play
#: operators of the model output; and through the model's own dynamics; and every input's
#: backlash through the dynamics; and each column also centred on its record mean (a memory state
#: before the record that the record itself does not fix). See :func:`_play_forms`.
PLAY_FORMS = ("output", "output_dynamic", "output_input", "full")


PLAY_FORM_TEXT = {
    "output": "of the model output",
    "output_dynamic": "of the model output, raw and through its dynamics",
    "output_input": "of the model output and inputs",
    "full": "of the model output and inputs, with the records' memory offsets",
}


def _play_columns(ctx: Context, r) -> dict:
    """The play-operator columns of record ``r`` by kind (``output``, ``output_dynamic``,
    ``input``: each (N, len(PLAY_FRACTIONS) [x inputs]), in the output's unit), cached per record."""
    cache = ctx._cache.setdefault("play_columns", {})
    key = id(r)
    if key not in cache:
        if "play_spans" not in ctx._cache:
            ctx._cache["play_spans"] = (
                float(np.ptp(ctx.yhat_est)) or 1.0,
                [float(np.ptp(ctx.u_est[:, i])) or 1.0 for i in range(ctx.n_in)],
            )
        span, spans_u = ctx._cache["play_spans"]
        out, dyn, inp = [], [], []
        for f in PLAY_FRACTIONS:
            d = play_operator(r.yhat, f * span) - r.yhat
            out.append(d)
            dyn.append(ctx.base_filter(d))
            for i in range(ctx.n_in):
                inp.append(ctx.base_filter(play_operator(r.u[:, i], f * spans_u[i]) - r.u[:, i]))
        cache[key] = (
            r,
            {"output": np.column_stack(out), "output_dynamic": np.column_stack(dyn), "input": np.column_stack(inp)},
        )
    return cache[key][1]


def _play_forms(ctx: Context) -> dict:
    """Regressor builders of rate-independent memory, one per form of :data:`PLAY_FORMS`.

    Play operators (radii :data:`PLAY_FRACTIONS` of each signal's span) of the model output minus
    the output (output-side memory), the same through the model's own dynamics, and of every input
    minus the input through the model's dynamics (input-side backlash); ``full`` adds each column
    centred on its record mean (an offset of the memory that the record itself does not fix)."""

    def form(name):
        def z(r):
            c = _play_columns(ctx, r)
            cols = [c["output"]]
            if name != "output":
                cols.append(c["output_dynamic"])
            if name in ("output_input", "full"):
                cols.append(c["input"])
            cols = np.column_stack(cols)
            if name == "full":
                cols = np.column_stack([cols, cols - cols.mean(axis=0)])
            return cols

        return z

    return {name: form(name) for name in PLAY_FORMS}


def _play_set(ctx: Context):
    """Regressors of rate-independent memory, its most general form (``full`` of
    :func:`_play_forms`): what the hysteresis test tests."""
    return _play_forms(ctx)["full"]
