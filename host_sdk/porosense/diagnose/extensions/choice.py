"""How a handler chooses between candidate extensions: by an information criterion at the
residual's effective sample size (:func:`_best_by_bic`), by leave-one-record-out prediction error
(:func:`record_out_error`), or on a held-out share of every estimation record (:func:`_choice_holdout`).
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose.extensions.context import Context

#: share of every estimation record a choice between extensions is fitted on; the rest scores it
CHOICE_FIT_SHARE = 0.7


def _choice_holdout(ctx: Context) -> np.ndarray:
    """Estimation samples that score a choice between extensions: the last 30 % of every record
    (the choice is fitted on the first 70 %, so an extension that fits the estimation records'
    levels and not new ones loses)."""
    return np.concatenate([np.arange(len(r.y)) >= CHOICE_FIT_SHARE * len(r.y) for r in ctx.est])


def _best_by_bic(ctx: Context, candidates: dict) -> str:
    """The key of ``candidates`` (regressor functions) with the smallest Bayesian information
    criterion on all estimation samples counted at their effective number:
    n_eff ln(RSS / N) + p ln(n_eff), RSS the squared residual of the extension fitted on every
    estimation record, p its number of regressors, N the estimation samples and n_eff their
    effective number, that of the residual of the candidate with the fewest regressors (the
    residual if no more complex side is needed; :func:`porosense.diagnose.calibrate.n_effective`
    per record, summed). Counted at N (in an F test) or scored on the last 30 % of every
    estimation record, the 36-term map between the linear blocks wins on the estimation records
    and loses on validation."""
    from porosense.diagnose.calibrate import n_effective

    y_est = np.concatenate([r.y for r in ctx.est])
    bounds = np.cumsum([0] + [len(r.y) for r in ctx.est])
    sizes = {k: ctx.stack(z, ctx.est[:1]).shape[1] for k, z in candidates.items()}
    resid = {k: y_est - ctx.fit_apply(z)[1] for k, z in candidates.items()}
    simplest = min(candidates, key=lambda k: sizes[k])
    n_eff = sum(n_effective(resid[simplest][a:b]) for a, b in zip(bounds[:-1], bounds[1:]))
    n_eff = max(n_eff, 2.0)
    n = len(y_est)

    def bic(k):
        rss = float(resid[k] @ resid[k])
        return n_eff * np.log(max(rss, 1e-300) / n) + sizes[k] * np.log(n_eff)

    return min(candidates, key=bic)


def record_out_error(ctx: Context, z_fn) -> float:
    """Leave-one-record-out prediction error of an extension, (output unit)^2.

    For each estimation record: the extension fitted on the other estimation records (their
    recording states refitted with it, :meth:`Context.fit_apply`), the held-out record predicted
    with its own state refitted on its residual, as a validation record's is; the squared errors
    summed over all records. What a validation record asks of an extension: to predict a record
    (a level, a stroke) it was not fitted on."""
    total, start = 0.0, 0
    for k, r in enumerate(ctx.est):
        n = len(r.y)
        mask = np.zeros(len(ctx.e_est), bool)
        mask[start : start + n] = True
        _, est, _, d_est = ctx._fit(z_fn, mask_est=mask)
        p = est[start : start + n]
        if r.state is not None:
            p = p - r.state.S @ d_est[k]
            p = p + r.state.S @ r.state.refit(r.y - p)
        total += float(np.sum((r.y - p) ** 2))
        start += n
    return total


def _best_by_record_out(ctx: Context, candidates: dict) -> str:
    """The key of ``candidates`` (regressor functions) of smallest leave-one-record-out prediction
    error (:func:`record_out_error`; at least two estimation records)."""
    errors = {k: record_out_error(ctx, z) for k, z in candidates.items()}
    return min(candidates, key=errors.get)
