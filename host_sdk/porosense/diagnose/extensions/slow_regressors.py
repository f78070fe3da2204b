"""The regressors the slow causes are told apart by: slow cosines and linear trends in time,
the output's static shape, the best slow mode of the inputs beyond the rivals' regressors
(:func:`_slow_sets`) and what the drift test is conditional on (:func:`_drift_base`).
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import signals
from porosense.diagnose.extensions.columns import _column_tests
from porosense.diagnose.extensions.context import GENERIC, Context
from porosense.diagnose.extensions.play import _play_set
from porosense.diagnose.extensions.static import _static_sets


def _trend_blocks(ctx: Context, n_terms: int = 3) -> np.ndarray:
    """Slow cosines of time, one block per estimation record (a separate trend in each file)."""
    blocks, start = [], 0
    total = sum(ctx.seg_est)
    for n in ctx.seg_est:
        B = np.zeros((total, n_terms))
        B[start : start + n] = signals.cosine_trend_basis(n, n_terms)
        blocks.append(B)
        start += n
    return np.column_stack(blocks)


def _trend(r) -> np.ndarray:
    """Offset and gain drifting linearly from the start of the record (time in s)."""
    return np.column_stack([r.t, r.t * r.yhat])


def _output_shape(ctx: Context):
    """yhat and its square (normalised): the static output-side shape a slow mode multiplies."""
    m, s = float(np.mean(ctx.yhat_est)), float(np.std(ctx.yhat_est)) or 1.0

    def z(r):
        yn = (r.yhat - m) / s
        return np.column_stack([r.yhat, yn * yn])

    return z, m, s


def _slow_sets(ctx: Context, rivals: tuple = ("hysteresis", "drift")):
    """(test, builder, tau) of the best slow-mode regressors, and the number of taus tried.

    A slow viscoelastic mode leaves a long exponential tail after every step: the residual
    follows the input after the model's own dynamics (the base filter) and the model output,
    both through a first-order lag of time constant tau, also scaled by the output level (the
    mode's share changes with the level). tau on a geometric grid (ratio 2) from twice the model's own
    time constant up to half a record. The test is conditional on static PWL maps
    of the level on every side and on the regressors of the ``rivals``: a drift in time (linear,
    and slow cosines per record) for ``drift``, play operators for ``hysteresis``, the condition
    column's dynamics and its scheduled gain for ``load_dependence``. What remains is
    memory that fades with tau and follows the input, which neither drift nor hysteresis has.
    """
    key = ("slow", tuple(rivals))
    if key in ctx._cache:
        return ctx._cache[key]
    t_rec = sum(ctx.seg_est) * ctx.ts / len(ctx.seg_est)
    tau = 2.0 * ctx.tau_s
    taus = []
    while tau < t_rec / 2:
        taus.append(tau)
        tau *= 2.0
    taus = taus or [t_rec / 4]
    shape, m, s = _output_shape(ctx)
    filtered = [np.column_stack([ctx.base_filter(r.u[:, i]) for i in range(ctx.n_in)]) for r in ctx.est + ctx.val]
    by_id = {id(r): f for r, f in zip(ctx.est + ctx.val, filtered)}
    z_h = _play_set(ctx)
    static = _static_sets(ctx)
    blocks = [ctx.stack(shape, ctx.est)]
    if "drift" in rivals:
        blocks += [ctx.stack(_trend, ctx.est), _trend_blocks(ctx, 2)]
    if "hysteresis" in rivals:
        blocks.append(ctx.stack(z_h, ctx.est))
    cols = _column_tests(ctx) if "load_dependence" in rivals else {}
    if cols:
        name = min(cols, key=lambda k: cols[k]["both"].log10_p)
        blocks += [ctx.stack(cols[name]["z_dyn"], ctx.est), ctx.stack(cols[name]["z_load"], ctx.est)]
    base = np.column_stack(blocks + [ctx.stack(zs, ctx.est) for zs in static.values()])
    best = None
    for tau in taus:
        a = float(np.exp(-ctx.ts / tau))

        def z(r, a=a, scaled=False):
            ly = ctx.lag_bank(r.yhat, 1, a)[:, 0]
            lu = [ctx.lag_bank(by_id[id(r)][:, i], 1, a)[:, 0] for i in range(ctx.n_in)]
            return np.column_stack([ly] + lu + ([ly * (r.yhat - m) / s] if scaled else []))

        # tested without the level-scaled tail (a static map of a dynamic output mimics it);
        # hysteresis is tested beyond the full set, and the extension uses it. A slow mode is
        # linear dynamics: tested beyond the generic correction, not the adequate-order one
        t = ctx.f_test(ctx.stack(z, ctx.est), extra_base=base, scope=GENERIC)
        if best is None or t.log10_p < best[0].log10_p:
            best = (t, lambda r, z=z: z(r, scaled=True), tau)
    ctx._cache[key] = (best, len(taus))
    return ctx._cache[key]


def _drift_base(ctx: Context, slow_rivals: tuple = ("hysteresis", "drift")) -> np.ndarray:
    """What the drift test is conditional on: the slow mode of the inputs (chosen beyond the
    regressors of ``slow_rivals``, :func:`_slow_sets`) and the output shape."""
    (_, z_slow, _), _ = _slow_sets(ctx, slow_rivals)
    shape, _, _ = _output_shape(ctx)
    return np.column_stack([ctx.stack(z_slow, ctx.est), ctx.stack(shape, ctx.est)])
