"""The extended model of the top cause: a model file, not only a set of predictions.

Where the on-device structure y = H2(g(sum_i H1_i(f_i(u_i)))) carries the extension, the
nominal model is re-identified with it by :mod:`porosense.ident` (the same identification the
nominal came from), so ``predict``, ``quantize`` and ``flash`` take it as they take any model:

    static_nonlinearity  Hammerstein (input side) or Wiener (output side / between), same orders
    saturation           Wiener (the clip is a flat end of g), same orders
    time_delay           the nominal structure with the found extra delay
    slow_relaxation      one more pole (and zero)
    unmodelled_dynamics  one more pole (and zero): "re-identify at a higher order"
    cross_coupling       the columns as other inputs (a MISO branch each, with its own dynamics)

Otherwise (hysteresis, load_dependence, drift, periodic_disturbance, outliers) it is a
:class:`porosense.ident.extended.ExtendedModel`: nominal + G0 + the cause's terms, in
simulation mode; quantising it is refused with :data:`ADVICE`.

Every model is fitted on the estimation records only and scored in simulation on the
validation records against nominal + G0 on the same samples.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import stats
from porosense.dsp.metrics import fit_percent, rms_percent
from porosense.errors import ModelError
from porosense.ident.extended import ExtendedModel, design, predict_settled, settle_samples

#: Why a cause's extension cannot run on the device, and what the user can do instead.
ADVICE = {
    "hysteresis": "the estimator structure has no memory operator (play/backlash); keep the extended model on "
    "the host, or identify a Wiener-Hammerstein model on data that covers both directions so that "
    "the device model averages the loop",
    "load_dependence": "the estimator sums its branches and cannot scale them by a measured load; identify one model "
    "per load (200 g, 500 g) and flash the one that matches, or keep the extended model on the host",
    "drift": "a drift that no input explains cannot be simulated; re-zero R0 at the start of every run or high-pass "
    "the measured output before identification (the one-step predictor figure shows what tracking the "
    "measured output would give on the host)",
    "periodic_disturbance": "an additive disturbance is not part of the input-to-output map; remove its source (pump "
    "PWM, mains pick-up) or notch-filter the measured output at its frequency before "
    "identification; the on-device estimate runs on the inputs and does not carry it",
    "outliers": "glitches in the measured output are not behaviour to model; the extended model is the robust refit "
    "(the on-device estimate runs on the inputs and never sees them); reject them in the data before "
    "identification",
}
FRACTIONS = (0.01, 0.03, 0.1, 0.3)


def _preroll_fit(model, us, ys, ts, inputs, output):
    """Fit ``model`` on records that start settled: each prefixed by its first input held for
    n_pre samples that are simulated and not scored (n_pre = 10 slowest time constants)."""
    n_pre = model.skip
    pre_u = [np.vstack([np.repeat(u[:1], n_pre, axis=0), u]) for u in us]
    pre_y = [np.concatenate([np.full(n_pre, y[0]), y]) for y in ys]
    return model.fit(u=pre_u, y=pre_y, ts=ts, inputs=inputs, output=output)


def refit(kind: str, nominal, us, ys, ts, inputs, **orders):
    """Re-identify a model of ``kind`` with the nominal's orders changed by ``orders``."""
    from porosense import ident

    base = {
        "n_poles": nominal.n_poles,
        "n_zeros": nominal.n_zeros,
        "n_breakpoints": nominal.n_breakpoints,
        "delay": nominal.delay,
    }
    base.update(orders)
    skip = max(settle_samples(nominal), 50)
    m = ident.make_model(kind, skip=skip, **base)
    return _preroll_fit(m, us, ys, ts, inputs, nominal.output)


def _structural(cause: str, res, ctx, nominal):
    """(model, validation input arrays) for an expressible cause, else None."""
    us = [r.u for r in ctx.est]
    ys = [r.y for r in ctx.est]
    inputs = tuple(nominal.inputs)
    if cause == "static_nonlinearity":
        kind = "hammerstein" if res.detail.get("side") == "input" else "wiener"
        return refit(kind, nominal, us, ys, ctx.ts, inputs), [r.u for r in ctx.val]
    if cause == "saturation" and res.detail.get("where") == "output":
        return refit("wiener", nominal, us, ys, ctx.ts, inputs), [r.u for r in ctx.val]
    if cause == "time_delay":
        # the residual's shift estimates the missing delay only roughly (the nominal model has
        # bent its dynamics to fit it): re-identify around it, keep the least estimation error
        d0 = int(res.detail["delay"])
        fits = [
            refit(nominal.kind, nominal, us, ys, ctx.ts, inputs, delay=nominal.delay + d)
            for d in range(max(1, d0 - 3), d0 + 4)
        ]
        return min(fits, key=lambda m: m.info["sse"]), [r.u for r in ctx.val]
    if cause in ("slow_relaxation", "unmodelled_dynamics"):
        poles = int(res.detail.get("n_poles", nominal.n_poles + 1))
        more = {"n_poles": poles, "n_zeros": min(nominal.n_zeros + poles - nominal.n_poles, poles - 1)}
        return refit(nominal.kind, nominal, us, ys, ctx.ts, inputs, **more), [r.u for r in ctx.val]
    cols = tuple(res.detail.get("columns", [res.detail.get("column")])) if cause == "cross_coupling" else ()
    if cols and len(inputs) + len(cols) <= 3:  # the on-device structure takes up to three inputs

        def with_cols(recs):
            return [np.column_stack([r.u] + [r.conditions[c] for c in cols]) for r in recs]

        return refit(nominal.kind, nominal, with_cols(ctx.est), ys, ctx.ts, tuple(inputs) + cols), with_cols(ctx.val)
    return None


def _terms(cause: str, res, ctx, nominal, yhat_est):
    """(terms, extra columns) of the wrapped extension: G0 and the cause's own terms."""
    n_in = len(nominal.inputs)
    terms = [{"type": "laguerre", "input": i, "pole": float(ctx.pole), "order": 4} for i in range(n_in)]
    terms.append({"type": "const"})
    columns = []
    span = float(np.ptp(yhat_est)) or 1.0
    if cause == "hysteresis":
        knots = [float(k) for k in np.unique(np.quantile(yhat_est, np.linspace(0, 1, 7)[1:-1]))]
        terms += [{"type": "output"}, {"type": "hinge_output", "knots": knots}]
        terms += [{"type": "play_output", "radius": f * span} for f in FRACTIONS]
        for i in range(n_in):
            su = float(np.ptp(ctx.u_est[:, i])) or 1.0
            terms += [
                {"type": "play_input", "input": i, "radius": f * su, "pole": float(ctx.pole), "order": 2}
                for f in FRACTIONS
            ]
    elif cause == "load_dependence":
        col = res.detail["column"]
        x = np.concatenate([r.conditions[col] for r in ctx.est])
        lo, sd = float(np.min(x)), float(np.std(x)) or 1.0
        knots = [float(k) for k in np.unique(np.quantile(yhat_est, np.linspace(0, 1, 7)[1:-1]))]
        columns = [col]
        terms += [
            {"type": "column", "input": n_in, "lo": lo, "scale": sd},
            {
                "type": "column_times_output",
                "input": n_in,
                "lo": lo,
                "scale": sd,
                "mean": float(np.mean(yhat_est)),
                "sd": float(np.std(yhat_est)) or 1.0,
                "knots": knots,
            },
        ]
    elif cause == "drift":
        terms += [{"type": "time"}]
    return terms, columns


def _wrapped(cause: str, res, ctx, nominal):
    """(ExtendedModel, validation input arrays) fitted on the estimation records."""
    n_pre = settle_samples(nominal)
    yh = [predict_settled(nominal, r.u, n_pre) for r in ctx.est]
    terms, columns = _terms(cause, res, ctx, nominal, np.concatenate(yh))

    def full(r):
        return np.column_stack([r.u] + [r.conditions[c] for c in columns]) if columns else r.u

    X = np.vstack([design(terms, full(r), y, ctx.ts) for r, y in zip(ctx.est, yh)])
    e = np.concatenate([r.y - y for r, y in zip(ctx.est, yh)])
    if cause == "outliers":
        step = max(stats.resolution(r.y) for r in ctx.est)
        mask, _, _ = stats.spike_mask(e, res.test.alpha, step, [len(r.y) for r in ctx.est])
        from porosense.diagnose.extensions import _huber_lstsq

        scale = np.linalg.norm(X[~mask], axis=0)
        scale[scale == 0] = 1.0
        coef = _huber_lstsq(X[~mask] / scale, e[~mask]) / scale
    else:
        coef = stats.lstsq(X, e)
    note = ADVICE.get(cause, "")
    model = ExtendedModel(nominal, cause, terms, coef, columns, note, n_pre)
    return model, [full(r) for r in ctx.val]


def build(cause: str, res, ctx, nominal):
    """(model, validation prediction, expressible) of ``cause``'s extension."""
    if hasattr(nominal, "models"):
        raise ModelError("extending a multi-output model set is not supported: diagnose one output's model")
    made = _structural(cause, res, ctx, nominal)
    expressible = made is not None
    if made is None:
        made = _wrapped(cause, res, ctx, nominal)
    model, val_u = made
    if expressible:
        pred = np.concatenate([predict_settled(model, u) for u in val_u])
    else:
        pred = np.concatenate([model.predict(u=u) for u in val_u])
    return model, pred, expressible


def attach(diag, ctx, results, nominal, baselines: dict) -> None:
    """Build the top cause's extended model, score it against the cause's baseline and attach it.

    baselines: validation predictions by baseline name (the engine's); the top finding's gain
    becomes the extended model's, against the same baseline on the same samples.
    """
    top = diag.findings[0]
    if top.cause not in results:
        return
    res = results[top.cause]
    if top.cause == "unmodelled_dynamics":
        res.detail["n_poles"] = max(nominal.n_poles + 1, int(diag.dynamics.get("data_order") or 0))
    model, pred, expressible = build(top.cause, res, ctx, nominal)
    keep = res.detail.get("score_mask", np.ones(len(ctx.y_val), bool))
    g0 = baselines.get(top.baseline, baselines["adequate"])
    fit0, fit1 = fit_percent(ctx.y_val[keep], g0[keep]), fit_percent(ctx.y_val[keep], pred[keep])
    top.fit_before, top.fit_after, top.gain = float(fit0), float(fit1), float(fit1 - fit0)
    top.rms_before, top.rms_after = rms_percent(ctx.y_val[keep], g0[keep]), rms_percent(ctx.y_val[keep], pred[keep])
    what = f"{model.kind} model re-identified" if expressible else "nominal + G0 + the cause's terms (host only)"
    top.on_device = (
        "expressible: quantize and flash take the extended model"
        if expressible
        else f"not expressible: {ADVICE.get(top.cause, '')}"
    )
    top.evidence += (
        f" Extended model ({what}): simulation fit on validation {fit1:.1f} % against {top.baseline} "
        f"{fit0:.1f} % on the same samples (gain {fit1 - fit0:+.2f} points). On the device: "
        f"{top.on_device}."
    )
    diag.extended = model
