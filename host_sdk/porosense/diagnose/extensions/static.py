"""The static map: regressors of a piecewise-linear map of the level on each side of the model's
dynamics (:func:`_static_sets`) and the static_nonlinearity handler.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import signals, stats
from porosense.diagnose.extensions.choice import _best_by_bic
from porosense.diagnose.extensions.context import CauseResult, Context, _explained


def _static_sets(ctx: Context) -> dict:
    """Regressor builders of a static PWL map on each side of the model's dynamics.

    output: hinge(yhat) (Wiener); input: the model's dynamics applied to hinge(u) (Hammerstein);
    between: the model's dynamics applied to hinge(yhat) (a nonlinearity inside the loop or
    between two linear blocks, Wiener-Hammerstein-like). Each side is a pair (linear, hinges):
    the linear counterpart applies the same filters to the signal itself, so that what the
    hinges add beyond it is the nonlinearity and not linear dynamics. The full builder of a
    side (both) is ``sets[side]``; the pairs are cached as ``ctx._cache["static_parts"]``.
    """
    if "static_sets" in ctx._cache:
        return ctx._cache["static_sets"]
    knots_out = signals.quantile_knots(ctx.yhat_est, 5)
    knots_in = [signals.quantile_knots(ctx.u_est[:, i], 5) for i in range(ctx.n_in)]
    x_mid = [ctx.lag_bank(ctx.u_est[:, i], 1)[:, 0] for i in range(ctx.n_in)]
    knots_mid = [signals.quantile_knots(x, 5) for x in x_mid]

    def filt(cols, both=True):
        out = []
        for c in cols:
            out.append(ctx.base_filter(c))
            if both:
                out.append(ctx.lag_bank(c, 1)[:, 0])
        return out

    def filt2(cols):
        # the second linear block of a Wiener-Hammerstein path is unknown: the model's own
        # dynamics and two Laguerre filters at its pole span the usual shapes
        out = []
        for c in cols:
            out += [ctx.base_filter(c)] + list(ctx.lag_bank(c, 2).T)
        return out

    def out_lin(r):
        return r.yhat[:, None]

    def out_nl(r):
        return signals.hinge_basis(r.yhat, knots_out)

    def in_lin(r):
        return np.column_stack([c for i in range(ctx.n_in) for c in filt([r.u[:, i]])])

    def in_nl(r):
        cols = []
        for i in range(ctx.n_in):
            cols += filt(signals.hinge_basis(r.u[:, i], knots_in[i]).T)
        return np.column_stack(cols)

    def mid_x(r, i):
        return ctx.lag_bank(r.u[:, i], 1)[:, 0]

    def mid_lin(r):
        return np.column_stack(filt2([r.yhat]) + [c for i in range(ctx.n_in) for c in filt2([mid_x(r, i)])])

    def mid_nl(r):
        cols = filt2(signals.hinge_basis(r.yhat, knots_out).T)
        for i in range(ctx.n_in):
            cols += filt2(signals.hinge_basis(mid_x(r, i), knots_mid[i]).T)
        return np.column_stack(cols)

    parts = {"output": (out_lin, out_nl), "input": (in_lin, in_nl), "between": (mid_lin, mid_nl)}

    def both(lin, nl):
        return lambda r: np.column_stack([lin(r), nl(r)])

    sets = {side: both(*p) for side, p in parts.items()}
    ctx._cache["static_sets"] = sets
    ctx._cache["static_parts"] = parts
    return sets


def static_nonlinearity(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a static nonlinearity the nominal model lacks.

    Test: F of the residual on a piecewise-linear (PWL) map of the level beyond its linear part,
    on each side (output: Wiener; input: Hammerstein; between the linear blocks), at alpha /
    sides; among the significant sides the one of smallest information criterion. Extension: the
    PWL of that side fitted on the estimation records (output units, as the record's y)."""
    sets = _static_sets(ctx)
    parts = ctx._cache["static_parts"]
    tests = {
        side: ctx.f_test(ctx.stack(nl, ctx.est), extra_base=ctx.stack(lin, ctx.est))
        for side, (lin, nl) in parts.items()
    }
    # the side: among those significant at the test's Bonferroni level, the one of smallest
    # information criterion at the residual's effective sample size (_best_by_bic: an F test at N
    # favours the 36-term map between the blocks, which can fit the estimation records' levels and
    # not the validation's); none significant, the strongest
    level = np.log10(alpha / len(tests))
    sig = [k for k in tests if tests[k].log10_p < level]
    if len(sig) > 1:
        side = _best_by_bic(ctx, {k: sets[k] for k in sig})
    else:
        side = sig[0] if sig else min(tests, key=lambda k: tests[k].log10_p)
    ctx._cache["static_side"] = side
    test, z = tests[side], sets[side]
    res = stats.f_result(
        f"F(residual ~ PWL of the level beyond its linear part, {side} side)", test, alpha, len(sets), side=side
    )
    pred, _ = ctx.fit_apply(z)
    kind = {
        "output": "Wiener: PWL on the output side",
        "input": "Hammerstein: PWL on the input side",
        "between": "PWL between the linear blocks (Wiener-Hammerstein)",
    }[side]
    return CauseResult(
        res,
        True,
        f"the residual depends on the signal level, best explained on the {side} side ({_explained(res)})",
        f"{kind}, 5 breakpoints",
        pred,
        {"side": side, **{f"p_{k}": t.p for k, t in tests.items()}},
        Z_est=ctx.stack(z, ctx.est),
        n_search=len(sets),
    )
