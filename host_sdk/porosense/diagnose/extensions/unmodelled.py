"""Unmodelled dynamics: linear dynamics beyond the model's order, shown by the adequate-order
correction's gain on the validation records.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import stats
from porosense.diagnose.extensions.context import ADEQUATE, GENERIC, CauseResult, Context, _explained


def unmodelled_dynamics(ctx: Context, alpha: float) -> CauseResult:
    """The nominal linear dynamics are too simple: the residual depends linearly on past inputs.

    Test (MATLAB resid's independence test, as a GLS F test): G0 and a second, faster Laguerre
    bank of every input against the nominal residual. Extension: the adequate-order linear
    correction of :mod:`..dynamics` (with G0), whose gain is measured against the nominal model;
    with a nominal model at hand the engine re-identifies it at a higher order (:mod:`..extend`).
    """
    # G0 and a second, faster Laguerre bank (2, 4 or 8 times faster than the dominant pole):
    # an order that is too low misses faster poles that a bank at the dominant pole renders poorly
    best = None
    for speed in (2.0, 4.0, 8.0):
        a = float(ctx.pole**speed)

        def z(r, a=a):
            return np.column_stack([ctx.lag_bank(r.u[:, i], 2, a) for i in range(ctx.n_in)])

        Z = np.column_stack([ctx.G0_est[:, :-1], ctx.stack(z, ctx.est)])
        t = stats.gls_f_test(ctx.e_est, Z, None, segments=ctx.seg_est)
        if best is None or t.log10_p < best[0].log10_p:
            best = (t, z, speed)
    test, _z_fast, speed = best
    res = stats.f_result("F(residual ~ Laguerre banks of past inputs)", test, alpha, 3, speed=speed)
    xc = [stats.input_crosscorrelation(ctx.u_est[:, i], ctx.e_est, 25, alpha) for i in range(ctx.n_in)]
    worst = max(xc, key=lambda t: t.strength)
    m = ctx.adequate.order
    # the name says the nominal needs more poles: the evidence disagrees when the generic
    # correction at the model's own order (G0) predicts the held-out data better than the
    # adequate-order correction (one-sided 5 %); what gains then is a retune that every other
    # cause's baseline carries too
    fewer = ud_fewer_poles(ctx)
    return CauseResult(
        res,
        True,
        f"the residual depends linearly on past inputs ({_explained(res)}; prewhitened "
        f"input-residual cross-correlation {worst.value:.3g} against the band {worst.threshold:.3g}, "
        f"p = {worst.p:.2g}); the residual's linear part needs {ctx.adequate.describe()}",
        f"re-identify at a higher order (here: a linear correction with {m} more pole{'s' if m > 1 else ''})",
        ctx.baseline_validation(ADEQUATE),
        {
            "xcorr_p": worst.p,
            "order": m,
            "evidence_ok": not fewer.confirmed,
            "evidence_note": "the data do not need more poles: the generic correction at the model's own order "
            f"(G0: its gain, offset and time scale retuned) predicts the held-out data better than the correction "
            f"with {m} more (paired t = {fewer.t:.3g}, one-sided p = {fewer.p:.2g})",
        },
        Z_est=ctx.A_est,
        n_search=len(ctx.adequate.bic),
    )


def ud_fewer_poles(ctx: Context) -> stats.GainTest:
    """Does nominal + G0 predict the validation records better than nominal + the adequate-order
    correction + G0? (paired per-sample improvement, batch means, one-sided at 5 %)"""
    return stats.paired_gain_test(ctx.y_val, ctx.baseline_validation(ADEQUATE), ctx.baseline_validation(GENERIC))
