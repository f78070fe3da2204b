"""The slow linear dynamics: slow_relaxation (a slow mode tested beyond the rivals with evidence of
their own, :func:`_slow_rivals`) and time_delay, each with its path for a calibrated simulator that
computes its own effect (:func:`_simulator_slow_relaxation`, :func:`_simulator_time_delay`).
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import dynamics, signals, stats
from porosense.diagnose.extensions.columns import _column_tests
from porosense.diagnose.extensions.context import (
    CONSTANT,
    DRIFT_TERMS,
    GENERIC,
    LAGUERRE_ORDER,
    OWN,
    POSTERIOR,
    CauseResult,
    Context,
    _explained,
    _simulated,
)
from porosense.diagnose.extensions.hysteresis import _hysteresis_test
from porosense.diagnose.extensions.slow_regressors import _drift_base, _slow_sets, _trend_blocks
from porosense.diagnose.extensions.static import static_nonlinearity

#: the rivals a slow mode is told apart from by conditioning (their regressors enter its test's base)
SLOW_RIVALS = ("hysteresis", "drift", "load_dependence")


def _slow_rivals(ctx: Context, alpha: float) -> tuple:
    """The rivals of a slow mode with evidence of their own: those whose test (a play operator's
    direction effect and a trend in time, both beyond the slow mode; a condition column that changes
    the output, Bonferroni over the columns) is significant at ``alpha``. A slow mode is tested beyond the regressors of these only: conditioned
    on a rival without evidence, a slow tail after steps that play operators or slow cosines also
    render (near-collinear regressors) would leave neither test any power. Each rival is tested
    beyond the slow mode chosen without its own regressors: a time constant chosen after a
    rival's regressors have taken the slow tail (a relaxation of 30 s looks like a trend within
    the 10 s holds of a step record) is one that leaves the tail to that rival's test."""
    tests = {
        "hysteresis": (_hysteresis_test(ctx, ("drift",)), 1),
        "drift": (ctx.f_test(_trend_blocks(ctx, DRIFT_TERMS), extra_base=_drift_base(ctx, ("hysteresis",))), 1),
    }
    cols = _column_tests(ctx)
    if cols:  # a condition column that changes the output (the load test, over the columns)
        tests["load_dependence"] = (min((c["both"] for c in cols.values()), key=lambda t: t.log10_p), len(cols))
    return tuple(
        r for r in SLOW_RIVALS if r in tests and stats.f_result(r, tests[r][0], alpha, tests[r][1]).significant
    )


def _sim_slow_taus(ctx: Context) -> np.ndarray:
    """Time constants (s) the simulator's slow_relaxation effect is searched over: a geometric
    grid of ratio sqrt(2) over the bounds ``porosense diagnose --sim --save-extended`` fits it
    within (porosense.sim.extend.EFFECT_FITS), kept where a slow mode can be told apart within the
    estimation records, as the residual regression's grid (:func:`_slow_sets`): no faster than
    dynamics.SLOW_RATIO times the model's own time constant (a fast mode is unmodelled dynamics),
    and no slower than half a record (one that does not relax within the record is a change of
    the gain to the level). The grid point nearest that range when none lies in it."""
    from porosense.sim.extend import EFFECT_FITS

    (_, lo, hi, _) = next(f for f in EFFECT_FITS["slow_relaxation"] if f[0] == "tau_s")
    grid = np.geomspace(lo, hi, int(np.ceil(np.log(hi / lo) / np.log(np.sqrt(2.0)))) + 1)
    t_rec = sum(ctx.seg_est) * ctx.ts / len(ctx.seg_est)
    floor, ceil = dynamics.SLOW_RATIO * ctx.tau_s, t_rec / 2.0
    keep = grid[(grid >= floor) & (grid <= ceil)]
    if keep.size:
        return keep
    return grid[[int(np.argmin(np.abs(np.log(grid / np.clip(grid, floor, max(ceil, floor))))))]]


def _slow_evidence(
    ctx: Context, alpha: float, res: stats.StatResult, tau: float, state_fit: str = POSTERIOR
) -> tuple[dict, object]:
    """What a slow mode's name needs beyond its gain: (detail, the slow-pole verdict or None).

    A gain from the slow mode itself: a static map of a dynamic output (a bend) changes its
    transients with the level, which a share of the output that follows it slowly renders in
    part, so the extension must predict the held-out data better than static_nonlinearity's
    extension beyond nominal + G0 (the engine's rival test, one-sided 5 %), as hysteresis'
    memory must. And a slow pole: a missing pole of the nominal is also a pole; a relaxation is
    one much slower than the nominal's slowest (the measured output re-identified with one pole
    more puts it there), a missing faster or nearby pole is unmodelled dynamics. ``state_fit``:
    how the rival's validation states are refitted (:data:`POSTERIOR` or :data:`OWN`), as the
    slow mode's own are."""
    static = static_nonlinearity(Context(ctx.est, ctx.val, correct=False, state_fit=state_fit), alpha)
    pole = None
    detail = {
        "tau_s": tau,
        "rival_val": static.yhat_val,
        "rival": "static_nonlinearity's extension (a static PWL of the level beyond nominal + G0)",
    }
    if res.significant:
        pole = dynamics.slow_pole(
            [r.u for r in ctx.est], [r.y for r in ctx.est], ctx.model_order or 1, ctx.slowest_tau_s, tau, ctx.ts
        )
        detail.update(
            {
                "prefers_slow": pole.slow,
                "evidence_ok": not pole.not_slow,
                "evidence_note": f"the pole the data need is not a slow one: {pole.sentence()}",
            }
        )
    return detail, pole


def _simulator_slow_relaxation(ctx: Context, alpha: float) -> CauseResult:
    """slow_relaxation of records from a calibrated simulator: the simulator's own effect
    (porosense.sim.effects), gain x (g - g through a first-order lag of tau) (1 + g / 100) added to
    dR, g the calibrated simulation's contact network (porosense.diagnose.calibrate.Simulation).
    It is linear in its gain for a given tau. The test: F of the effect beyond the generic
    correction (a slow mode is linear dynamics), tau the most significant of :func:`_sim_slow_taus`
    (Bonferroni over them). The extension: the effect alone on the nominal (its gain and a
    constant, each record's recording state refitted beside it), tau the one of the grid that fits
    the estimation records best; found only where it also predicts the held-out records better
    than nominal + G0 (the correction its test is beyond). Its gain is measured against the
    nominal itself, whose validation records carry the state their own fit gave (calibrate.Calibration.predict_record): each
    validation record's state is refitted after the effect by that same rule (:data:`OWN`), as is
    the rival static map's and nominal + G0's. Refitted by the posterior instead (:data:`POSTERIOR`),
    the nominal's own validation records move by -0.74 to +0.92 fit points with nothing added
    (the slow_relaxation trials of tests/diagnose/test_diagnose_sim.py, seeds 1000-1011), a change
    the effect's gain carried."""
    taus = _sim_slow_taus(ctx)

    def z(r, tau):
        return r.simulation.slow_relaxation(tau)[:, None]

    best = None
    for tau in taus:
        t = ctx.f_test(ctx.stack(lambda r, tau=tau: z(r, tau), ctx.est), scope=GENERIC)
        if best is None or t.log10_p < best[0].log10_p:
            best = (t, tau)
    test, tau_test = best
    res = stats.f_result(
        "F(residual ~ the simulator's slow_relaxation effect)", test, alpha, len(taus), tau_s=float(tau_test)
    )
    y_all = np.concatenate([r.y for r in ctx.est])
    sse = {
        float(t): float(np.sum((y_all - ctx.fit_apply(lambda r, t=t: z(r, t), scope=CONSTANT)[1]) ** 2)) for t in taus
    }
    tau = min(sse, key=sse.get)
    pred, _ = ctx.fit_apply(lambda r: z(r, tau), scope=CONSTANT, state_fit=OWN)
    detail, pole = _slow_evidence(ctx, alpha, res, tau, state_fit=OWN)
    # the test is beyond the generic correction (a slow mode is linear dynamics), and a dynamics
    # cause must show a gain from its own terms against nominal + G0 (porosense.diagnose.engine,
    # rule 1): the effect must predict the held-out records better than nominal + G0 (its gain,
    # offset and time scale retuned, the states refitted alike), one-sided 5 %
    g0_val, _ = ctx.fit_apply(None, scope=GENERIC, state_fit=OWN)
    beyond = stats.paired_gain_test(ctx.y_val, g0_val, pred)
    if not beyond.confirmed:
        notes = [detail["evidence_note"]] if not detail.get("evidence_ok", True) else []
        detail.update(
            {
                "evidence_ok": False,
                "evidence_note": "; ".join(
                    notes
                    + [f"no held-out gain against nominal + G0 (t = {beyond.t:.3g}, one-sided p = {beyond.p:.2g})"]
                ),
            }
        )
    return CauseResult(
        res,
        True,
        f"the residual follows the simulator's slow relaxation of its contact network with tau about "
        f"{tau_test:.3g} s ({_explained(res)}" + (f"; {pole.sentence()}" if pole is not None else "") + ")",
        f"the simulator's slow_relaxation effect at tau = {tau:.3g} s",
        pred,
        detail,
        Z_est=ctx.stack(lambda r: z(r, tau), ctx.est),
        n_search=len(taus),
    )


def slow_relaxation(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a slow relaxation (a mode much slower than the model's own).

    Records of a calibrated simulator: the simulator's own slow_relaxation effect on each
    record's simulation. Otherwise: F of the residual on slowly filtered inputs (time constants
    in s from SLOW_RATIO times the model's own) beside its rivals' regressors; the extension is the
    nominal re-identified with one extra pole at the time constant fitted best."""
    if _simulated(ctx):
        return _simulator_slow_relaxation(ctx, alpha)
    rivals = _slow_rivals(ctx, alpha)
    (test, _z, tau), n_taus = _slow_sets(ctx, rivals)
    res = stats.f_result(
        f"F(residual ~ slowly filtered input | {', '.join(rivals) or 'static maps'})",
        test,
        alpha,
        n_taus,
        tau_s=tau,
        rivals=list(rivals),
    )

    def z_full(r, tau_x):
        # the nominal re-identified with one extra pole: a share of the model output that follows
        # it with the time constant tau, and a short Laguerre bank of the inputs at the model's
        # own pole (the nominal bent its fast dynamics to fit the slow mode)
        banks = [ctx.lag_bank(r.u[:, i], 2) for i in range(ctx.n_in)]
        return np.column_stack([r.yhat, ctx.lag_bank(r.yhat, 1, float(np.exp(-ctx.ts / tau_x)))[:, 0]] + banks)

    # the extension alone on the nominal (no generic correction): its gain is the slow mode's own;
    # its time constant the one that fits the estimation records best (the test's is a first guess)
    y_all = np.concatenate([r.y for r in ctx.est])
    # a relaxation is slow: no faster than the test's shortest time constant (SLOW_RATIO times
    # the model's own), or the extension would be a fast mode under a slow mode's name
    floor = dynamics.SLOW_RATIO * ctx.tau_s
    grid = [t for t in (tau * f for f in (0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0)) if t >= floor] or [tau]
    sse = {t: float(np.sum((y_all - ctx.fit_apply(lambda r, t=t: z_full(r, t), scope=CONSTANT)[1]) ** 2)) for t in grid}
    tau = min(sse, key=sse.get)
    pred, _ = ctx.fit_apply(lambda r: z_full(r, tau), scope=CONSTANT)
    detail, pole = _slow_evidence(ctx, alpha, res, tau)
    return CauseResult(
        res,
        True,
        f"the residual follows the input through a slow mode of about {tau:.3g} s "
        f"({_explained(res)}; the model's own time constant is {ctx.tau_s:.3g} s"
        + (f"; {pole.sentence()}" if pole is not None else "")
        + ")",
        f"an extra relaxation pole at tau = {tau:.3g} s",
        pred,
        detail,
        Z_est=ctx.stack(lambda r: z_full(r, tau), ctx.est),
        n_search=n_taus,
    )


def _response_rise(ctx: Context, d_max: int, whose: str):
    """(the input whose measured step response rises latest against the prediction's, whether it
    rises later, a sentence saying at which lags, in samples): a dead time's own evidence."""
    y_est = np.concatenate([r.y for r in ctx.est])
    span = int(min(200, d_max + 4 * max(1.0, ctx.tau_s / ctx.ts)))
    rises = [stats.response_rises(ctx.u_est[:, i], y_est, ctx.yhat_est, span) for i in range(ctx.n_in)]
    shown = max(rises, key=lambda p: p.measured - p.model)
    note = (
        f"the measured step response (running sum of the prewhitened input-output cross-correlation) "
        f"reaches {100 * stats.RISE_SHARE:.0f} % at lag {shown.measured}, {whose} at lag {shown.model}"
    )
    return shown, shown.measured > shown.model, note


def _simulator_time_delay(ctx: Context, alpha: float) -> CauseResult:
    """time_delay of records from a calibrated simulator: the simulator's own effect
    (porosense.sim.effects: the reading lags the physics by delay_s), its calibrated simulation
    delayed by whole samples. The test: F of the simulation delayed less the simulation beyond
    the generic correction, the delay the most significant of 1 sample up to the bound
    ``porosense diagnose --sim --save-extended`` fits it within (porosense.sim.extend.EFFECT_FITS)
    and a twentieth of the shortest estimation record (Bonferroni over them). The extension: the
    whole simulation delayed and a constant (each record's recording state refitted beside it),
    the delay the one that fits the estimation records best. The name needs its own
    evidence: the measured response rises later than the simulation's (as for any model), and the
    delayed simulation predicts the held-out data better than the undelayed one with the same
    constant and states refitted (the engine's rival test). Whether
    a dead time or one more pole explains the linear deficit is judged on the simulator itself:
    its delayed simulation against the corrected one on held-out data (the engine's overlap rule
    for the dynamics causes), not by linear models of the measured output, which a nonlinear
    simulator's output does not follow."""
    from porosense.sim.extend import EFFECT_FITS

    (_, _, hi, _) = next(f for f in EFFECT_FITS["time_delay"] if f[0] == "delay_s")
    d_max = int(max(1, min(round(hi / ctx.ts), min(ctx.seg_est) // 20)))

    def z(r, lag):
        return (signals.shift(r.yhat, lag) - r.yhat)[:, None]

    best = None
    for d in range(1, d_max + 1):
        t = ctx.f_test(ctx.stack(lambda r, d=d: z(r, d), ctx.est), scope=GENERIC)
        if best is None or t.log10_p < best[0].log10_p:
            best = (t, d)
    test, d_test = best
    res = stats.f_result(
        "F(residual ~ the simulator's time_delay effect)", test, alpha, d_max, delay_samples=int(d_test)
    )

    # the extension is the effect itself: the whole simulation delayed (a share of it delayed
    # would be a low-pass of the simulation under a delay's name, which a long shift renders)
    def delayed(r, lag):
        return signals.shift(r.yhat, lag) - r.yhat

    y_all = np.concatenate([r.y for r in ctx.est])
    sse = {
        d: float(np.sum((y_all - ctx.fit_apply(scope=CONSTANT, fixed=lambda r, d=d: delayed(r, d))[1]) ** 2))
        for d in range(1, d_max + 1)
    }
    d = min(sse, key=sse.get)
    pred, _ = ctx.fit_apply(scope=CONSTANT, fixed=lambda r: delayed(r, d))
    shown, later, peak_note = _response_rise(ctx, d_max, "the simulation's")
    return CauseResult(
        res,
        True,
        f"the measurement lags the simulation by about {d_test} samples ({d_test * ctx.ts:.3g} s; {peak_note})",
        f"the simulator's time_delay effect of {d} samples ({d * ctx.ts:.3g} s)",
        pred,
        {
            "delay": d,
            "n_params": 2,  # the delay and the constant
            "rise_measured": shown.measured,
            "rise_model": shown.model,
            "evidence_ok": bool(later),
            "evidence_note": "" if later else f"no delay in the data: {peak_note}",
            "prefers_delay": False,
            # the gain must come from the delay, not from the constant and the states refitted
            # with it (the engine's rival test, one-sided 5 %)
            "rival_val": ctx.fit_apply(scope=CONSTANT)[0],
            "rival": "the simulation with its constant and recording states refitted, undelayed",
        },
        Z_est=ctx.stack(lambda r: delayed(r, d)[:, None], ctx.est),
        n_search=d_max,
    )


def time_delay(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a dead time in front of the model.

    Records of a calibrated simulator: the whole simulation delayed by whole samples. Otherwise:
    F of the residual on the model output delayed by 1..d_max samples (the best delay, tested at
    alpha / d_max) with the delayed inputs' Laguerre bank; the extension is the nominal
    re-identified with that delay (the delay is reported in samples of the record's period)."""
    if _simulated(ctx):
        return _simulator_time_delay(ctx, alpha)
    d_max = int(min(25, max(2, min(ctx.seg_est) // 20)))
    best = None
    for d in range(1, d_max + 1):

        def z(r, d=d):
            # the model output delayed, and the delayed inputs through a short Laguerre bank (a
            # delay in front of dynamics the nominal model has partly bent to fit it)
            banks = [ctx.lag_bank(signals.shift(r.u[:, i], d), 2) for i in range(ctx.n_in)]
            return np.column_stack([signals.shift(r.yhat, d) - r.yhat] + banks)

        t = ctx.f_test(ctx.stack(z, ctx.est), scope=GENERIC)
        if best is None or t.log10_p < best[0].log10_p:
            best = (t, z, d)
    test, z, d = best
    xc = stats.input_crosscorrelation(ctx.u_est[:, 0], ctx.e_est, 25, alpha)
    res = stats.f_result("F(residual ~ model output delayed)", test, alpha, d_max, delay_samples=d)
    # the extension: the nominal re-identified with the delay (its own output to cancel it, and a
    # Laguerre bank of the delayed inputs), without the generic correction: its gain is the
    # delay's own

    def z_ext(r, lag):
        # a dead time in front of the model is the model's own prediction delayed (exact for any
        # time-invariant model started at rest, a simulator too); the bank of the delayed inputs
        # re-identifies the dynamics the nominal bent to fit the delay
        banks = [ctx.lag_bank(signals.shift(r.u[:, i], lag)) for i in range(ctx.n_in)]
        return np.column_stack([r.yhat, signals.shift(r.yhat, lag)] + banks)

    # the delay of the extension: the one whose re-identification fits the estimation records best
    y_all = np.concatenate([r.y for r in ctx.est])
    sse = {}
    for lag in range(1, d_max + 1):
        sse[lag] = float(np.sum((y_all - ctx.fit_apply(lambda r, lag=lag: z_ext(r, lag), scope=CONSTANT)[1]) ** 2))
    d = min(sse, key=sse.get)
    pred, _ = ctx.fit_apply(lambda r: z_ext(r, d), scope=CONSTANT)
    # the name needs its own evidence: the measured response rises later than the model's
    shown, later, peak_note = _response_rise(ctx, d_max, "the model's")
    evidence_ok, note = bool(later), "" if later else f"no delay in the data: {peak_note}"
    # a missing pole also makes the response rise late: the data must prefer a dead time to one
    # more pole on held-out data (judged where the test and the rise agree)
    choice = None
    if later and res.significant:
        choice = dynamics.delay_or_pole(
            [r.u for r in ctx.est],
            [r.y for r in ctx.est],
            [r.u for r in ctx.val],
            [r.y for r in ctx.val],
            ctx.model_order or 1,
            (d - 1, d, d + 1),
            [r.yhat for r in ctx.val],
        )
        peak_note += f"; {choice.sentence()}"
        if choice.prefers_pole:
            evidence_ok, note = False, f"a lag, not a dead time: {choice.sentence()}"
    return CauseResult(
        res,
        True,
        f"the measurement lags the model by about {d} samples ({d * ctx.ts:.3g} s; {peak_note}; "
        f"prewhitened input-residual cross-correlation peaks at lag {xc.detail['peak_lag']})",
        f"an input delay of {d} samples",
        pred,
        {
            "delay": d,
            "n_params": 2 + LAGUERRE_ORDER * ctx.n_in + 1,
            "rise_measured": shown.measured,
            "rise_model": shown.model,
            "evidence_ok": evidence_ok,
            "evidence_note": note,
            "prefers_delay": bool(choice is not None and choice.prefers_delay),
        },
        Z_est=ctx.stack(z, ctx.est),
        n_search=d_max,
    )
