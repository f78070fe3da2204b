"""Saturation: outputs piled up at a limit of the record while the inputs are away from rest,
and the handler that names it and extends the model.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import binom as sps_binom

from porosense.diagnose import signals, stats
from porosense.diagnose.extensions.choice import _choice_holdout
from porosense.diagnose.extensions.context import CauseResult, Context
from porosense.diagnose.extensions.static import _static_sets


def _record_limit(y: np.ndarray, side: str, default: float) -> float:
    """The record's own clip level: its extreme on ``side`` if at least 10 samples sit there
    exactly (each file's dR has its own R0 calibration, so the same ADC limit moves), else default."""
    ext = float(y.min() if side == "low" else y.max())
    at = np.abs(y - ext) <= 1e-6 * (float(np.ptp(y)) or 1.0)
    return ext if at.sum() >= 10 else default


#: the first samples of a record whose range is within this share of the record's span are a hold
#: at the record's rest level (measurement noise of a few % of the span is allowed)
START_HOLD_SHARE = 0.1


START_HOLD_SAMPLES = 10


def _start_level(x: np.ndarray) -> float:
    """An input's own rest level (its units): :func:`..signals.rest_level` with a hold that allows
    measurement noise (START_HOLD_SAMPLES within START_HOLD_SHARE of the span)."""
    return signals.rest_level(x, hold=START_HOLD_SAMPLES, tol=START_HOLD_SHARE)


def _inputs_away_from_rest(ctx: Context, censored: np.ndarray) -> stats.ExcessTest:
    """Are the inputs further from their own rest level at the ``censored`` estimation samples than
    at the others? (distance |u - rest level| in shares of its span, run means, one-sided at 5 % /
    inputs; the input that goes furthest). At a clip the inputs go beyond where the output leaves
    the limit (a cycle's peak); at a rest they sit at their rest level (zero strain between cycles)."""
    tests = []
    for i in range(ctx.n_in):
        d = np.concatenate([np.abs(r.u[:, i] - _start_level(r.u[:, i])) for r in ctx.est])
        d = d / (float(np.ptp(ctx.u_est[:, i])) or 1.0)
        ref = float(np.mean(d[~censored])) if (~censored).any() else 0.0
        tests.append(stats.mean_excess_test(d - ref, censored, alpha=stats.CONFIRM_ALPHA / ctx.n_in))
    return max(tests, key=lambda t: (t.t, t.mean))


def saturation(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of clipping of the measured output at a limit (a divider or ADC range).

    Test: samples piling up at one extreme value of each estimation record's output, beyond
    what its distribution gives, with the model's excess beyond that limit as the F test's
    regressor; a rest at the limit (where the model, fitted without those samples, predicts no
    excess and the input is at its rest level) is not clipping. Extension: the model output, or
    the generic correction refitted on the unclipped samples, clipped at each record's limit
    (output units)."""
    y_est = np.concatenate([r.y for r in ctx.est])
    # tested per record: a limit in dR moves with each record's R0 calibration
    # only the measured output: an input that sits exactly at its extreme is, for a command, its
    # rest level, which no statistic tells apart from a clipped measured input
    candidates = [("output", None, stats.limit_clustering(r.y, alpha)) for r in ctx.est]
    where, idx, clus = min(candidates, key=lambda c: c[2].p)
    n_sig = len(candidates)
    limit, side = clus.detail["limit"], clus.detail["side"]
    if idx is None:

        def z(r):
            over = r.yhat - _record_limit(r.y, side, limit)
            return np.maximum(over, 0.0) if side == "high" else np.minimum(over, 0.0)
    else:
        span = float(np.ptp(ctx.u_est[:, idx])) or 1.0

        def z(r):
            at = (np.abs(r.u[:, idx] - limit) <= 1e-6 * span).astype(float)
            return ctx.lag_bank(at, 2)

    test = ctx.f_test(ctx.stack(z, ctx.est))
    ftest = stats.f_result("F(residual ~ excess beyond the limit)", test, alpha)
    p = min(1.0, clus.p * n_sig)
    # a pile-up at one exact value is evidence no other cause produces: the two tests add up
    strength = clus.strength - np.log10(n_sig) + (ftest.strength if ftest.significant else 0.0)
    res = stats.StatResult(
        f"samples at the {side} limit of the {where}",
        clus.value,
        clus.threshold,
        p,
        alpha,
        {**clus.detail, "f_test": ftest.value},
        log10_p=-strength,
    )
    if idx is None:
        # clipped samples are censored: they say only that the output is beyond the limit
        lim_est = np.concatenate([np.full(len(r.y), _record_limit(r.y, side, limit)) for r in ctx.est])
        lim_val = np.concatenate([np.full(len(r.y), _record_limit(r.y, side, limit)) for r in ctx.val])
        censored = np.abs(y_est - lim_est) <= 1e-6 * (float(np.ptp(y_est)) or 1.0)
        clip = np.maximum if side == "low" else np.minimum
        # the clip alone, or the clip after the generic correction refitted on unclipped samples:
        # chosen on the last 30 % of every estimation record, fitted on the first 70 %
        holdout = _choice_holdout(ctx)
        _, refit_est = ctx.fit_apply(None, mask_est=censored | holdout)
        rss_refit = float(np.sum((y_est - clip(refit_est, lim_est))[holdout] ** 2))
        rss_clip = float(np.sum((y_est - clip(ctx.yhat_est, lim_est))[holdout] ** 2))
        unclipped_val, unclipped_est = ctx.fit_apply(None, mask_est=censored)
        pred = clip(unclipped_val, lim_val) if rss_refit < rss_clip else clip(ctx.yhat_val, lim_val)
        # a rest is where the output sits by design (the record's rest level: the model predicts
        # it there too); clipping cuts off what the model predicts beyond the limit
        beyond = (lim_est - unclipped_est) if side == "low" else (unclipped_est - lim_est)
        excess = stats.mean_excess_test(beyond, censored)
        away = _inputs_away_from_rest(ctx, censored)
    else:
        pred, _ = ctx.fit_apply(z)
        excess = away = None
    # the pile-up is evidence of its own (independent of the residual regression): its binomial
    # log-likelihood ratio against the null share of 1/2 enters the ranking. The ranked model is
    # a clip at the measured limit on top of a static output-side map (noise smooths the
    # transition into the clip, which a hard clip alone does not render)
    k_at, k_ref = clus.detail["k_at"], clus.detail["k_near"]
    share = k_at / max(k_at + k_ref, 1)
    llr = 0.0
    if k_at + k_ref > 0 and p < alpha:
        llr = float(sps_binom.logpmf(k_at, k_at + k_ref, share) - sps_binom.logpmf(k_at, k_at + k_ref, 0.5))
    rest_note = ""
    if excess is not None:
        rest_note = (
            f"; fitted without them, the model predicts {excess.mean:.3g} beyond the limit there on average "
            f"(t = {excess.t:.3g} over {excess.groups} runs at the limit, one-sided p = {excess.p:.2g}); "
            f"there the input is {away.mean:+.3g} of its span further from its rest level than elsewhere "
            f"(t = {away.t:.3g} over {away.groups} runs, one-sided p = {away.p:.2g})"
        )
    # clipping: the output sits at the limit while the model's prediction, or the input, goes
    # beyond it; a rest: neither (the output rests there because the input rests at its own rest level)
    evidence_ok = excess is None or excess.confirmed or away.confirmed
    return CauseResult(
        res,
        p < alpha,
        f"{clus.detail['k_at']} samples ({100 * clus.detail['fraction']:.1f} % of "
        f"the record) sit exactly at the {side} limit {limit:.4g} of the {where}{rest_note}",
        f"clipping of the {where} at its limit (ADC/divider)",
        pred,
        {
            "limit": limit,
            "where": where,
            "evidence_ok": bool(evidence_ok),
            "evidence_note": ""
            if evidence_ok
            else "the output rests at the limit (the model, fitted without those samples, does not predict "
            "beyond it there, and the input is not further from its rest level there than elsewhere): a rest of "
            "the experiment, not clipping",
        },
        Z_est=np.column_stack([ctx.stack(_static_sets(ctx)["output"], ctx.est), ctx.stack(z, ctx.est)]),
        n_search=n_sig,
        evidence_llr=llr,
    )
