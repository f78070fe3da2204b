"""Disturbances of the measurement and of the recording: drift (incl. the test of a record's
recording state, :func:`_state_drift_test`), periodic_disturbance and outliers.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import signals, stats
from porosense.diagnose.extensions.context import ADEQUATE, DRIFT_TERMS, FIT_RCOND, CauseResult, Context, _explained
from porosense.diagnose.extensions.slow_regressors import _drift_base, _trend, _trend_blocks


def _ema_causal(x: np.ndarray, a: float) -> np.ndarray:
    """Exponential average of x up to k-1 (causal one-step-ahead estimate)."""
    from scipy import signal

    m = signal.lfilter([1.0 - a], [1.0, -a], x)
    return np.concatenate([[0.0], m[:-1]])


def _track_per_record(records, resid: np.ndarray, fn) -> np.ndarray:
    out, start = [], 0
    for r in records:
        n = len(r.y)
        out.append(fn(r, resid[start : start + n]))
        start += n
    return np.concatenate(out)


def _has_drift_state(records) -> bool:
    return all(r.state is not None and "drift" in getattr(r.state, "names", ()) for r in records)


def _drift_column(r) -> np.ndarray:
    """The record's drift state column: output change per % of R0 per minute of R0 drift."""
    return r.state.S[:, r.state.names.index("drift")]


def _state_drift_test(ctx: Context, alpha: float) -> stats.StatResult:
    """Do the estimation records share an R0 drift beyond what the simulator says repeats differ by?

    Every record carries its recording state (calibrate.StateColumns), whose drift the simulator
    draws per recording from its prior N(0, sd^2) (% of R0 per minute; the fit bounds it to the
    prior's central 99 % interval |rate| <= Z_PRIOR sd). Here each record's drift rate r_i is
    fitted without that bound, jointly with the other Gaussian states (under their prior), the
    baseline correction and what the trend test is conditional on (the slow mode of the inputs,
    the output shape); each record's data weighted by w = n_eff / (N sigma^2) of its own residual
    (calibrate.n_effective; one reweighting), so the rate's standard error is the long-run one of
    a coloured residual; R0's random walk, which the rate absorbs and the residual then does not
    show, adds its own (StateColumns.walk_rate_sd) in quadrature: se_i. A drift of the sensor
    (ageing, temperature) adds one rate d to every record: r_i = d + s_i + noise, s_i ~ N(0, sd_i^2)
    the recording's own draw, so r_i ~ N(d, v_i), v_i = sd_i^2 + se_i^2 (the records' noise is
    independent: they share only the baseline's few coefficients). The statistic is the
    generalised least-squares estimate of d over its standard error,
    z = (sum r_i / v_i) / sqrt(sum 1 / v_i), standard normal when d = 0; p two-sided (a drift
    of either sign). At the simulator trials' seeds 1000-1011 the clean contractor records give
    |z| <= 2.2 (z spread as N(0, 1)), those with a hidden drift of 1-3 % per minute z = 4.1-9.2."""
    from scipy.stats import norm

    from porosense.diagnose.calibrate import Z_PRIOR, n_effective

    recs = ctx.est
    Xb = np.column_stack([ctx.base(ADEQUATE)[0], _drift_base(ctx)])
    n_b = Xb.shape[1]
    Se = ctx._state_blocks()[0]  # every record carries a state (_has_drift_state)
    K = Se.shape[1]
    P_rows, P_t, spans, drift_col = [], [], [], []
    row = col = 0
    for r in recs:
        st, n = r.state, len(r.y)
        k = st.S.shape[1]
        sw = np.sqrt(st.weight())
        for j, name in enumerate(st.names):
            if name == "drift":
                drift_col.append(col + j)
                continue
            p = np.zeros(n_b + K)
            p[n_b + col + j] = 1.0 / st.sd[j]
            P_rows.append(p)
            P_t.append(st.t[j] * sw)  # the prior's pull back in its own unit (P d = t sqrt(w))
        spans.append((row, row + n))
        row += n
        col += k
    X = np.column_stack([Xb, Se])
    P = np.array(P_rows).reshape(-1, n_b + K)
    w = [r.state.weight() for r in recs]
    for _ in range(2):
        sw = np.concatenate([np.full(b - a, np.sqrt(wi)) for (a, b), wi in zip(spans, w)])
        A = np.vstack([X * sw[:, None], P])
        y = np.concatenate([ctx.e_est * sw, P_t])
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        U, sv, Vt = np.linalg.svd(A / scale, full_matrices=False)
        keep = sv > FIT_RCOND * sv[0]
        coef = (Vt[keep].T @ ((U[:, keep].T @ y) / sv[keep])) / scale
        e = ctx.e_est - X @ coef
        w = []
        for a, b in spans:
            v = float(np.mean(e[a:b] ** 2))
            w.append(n_effective(e[a:b]) / ((b - a) * v) if v > 0 else 1.0)
    rates, ses, bounds = [], [], []
    for r, j in zip(recs, drift_col):
        c = n_b + j
        # coefficient covariance (A'A)^-1 of the weighted problem (unit noise), in the drift's unit
        vj = Vt[keep][:, c] / scale[c]
        se = float(np.sqrt(np.sum((vj / sv[keep]) ** 2) + r.state.walk_rate_sd**2))
        rate = r.state.value("drift") + float(coef[c])
        bound = Z_PRIOR * float(r.state.sd[r.state.names.index("drift")])
        rates.append(rate)
        ses.append(se)
        bounds.append(bound)
    v = (np.array(bounds) / Z_PRIOR) ** 2 + np.array(ses) ** 2
    common = float(np.sum(np.array(rates) / v) / np.sum(1.0 / v))
    common_se = float(1.0 / np.sqrt(np.sum(1.0 / v)))
    z = common / common_se
    log10_p = float((np.log(2.0) + norm.logsf(abs(z))) / np.log(10.0))
    return stats.StatResult(
        "z(common R0 drift rate of the records beyond their prior spread)",
        abs(z),
        float(norm.isf(alpha / 2.0)),
        max(10.0**log10_p, 1e-300),
        alpha,
        {
            "rate_pct_per_min": [round(x, 4) for x in rates],
            "se_pct_per_min": [round(x, 4) for x in ses],
            "bound_pct_per_min": [round(x, 4) for x in bounds],
            "common_pct_per_min": round(common, 4),
            "common_se_pct_per_min": round(common_se, 4),
        },
        log10_p=min(0.0, log10_p),
    )


def drift(ctx: Context, alpha: float) -> CauseResult:
    """A slow trend in time that no input explains. Records that carry their recording state
    with a drift (a calibrated simulation's): is a record's R0 drift beyond what the simulator
    says repeats differ by (:func:`_state_drift_test`, :func:`_drift_beyond_state`)? Others: the
    F test of slow cosines of time per record beyond the slow mode of the inputs, the extension
    an offset and gain drifting linearly, the predictor a drift tracked from the output."""
    n_terms = DRIFT_TERMS

    def z(r, recs=None):
        return signals.cosine_trend_basis(len(r.y), n_terms)

    # a trend that no input explains: conditional on the slow mode of the inputs
    test = ctx.f_test(_trend_blocks(ctx, n_terms), extra_base=_drift_base(ctx))
    res = stats.f_result("F(residual ~ slow trend in time | slow mode)", test, alpha)
    if _has_drift_state(ctx.est + ctx.val):
        return _drift_beyond_state(ctx, alpha, res)
    pred_g0_val, pred_g0_est = ctx.fit_apply(None)
    r_est = np.concatenate([r.y for r in ctx.est]) - pred_g0_est
    r_val = ctx.y_val - pred_g0_val
    t_rec = min(ctx.seg_est) * ctx.ts
    best = None
    for tau in (t_rec / 40, t_rec / 15, t_rec / 6):
        tau = max(tau, 5 * ctx.tau_s)
        a = float(np.exp(-ctx.ts / tau))
        trk = _track_per_record(ctx.est, r_est, lambda rec, x: _ema_causal(x, a))
        rss = float(np.sum((r_est - trk) ** 2))
        if best is None or rss < best[0]:
            best = (rss, a, tau)
    _, a, tau = best
    pred_trk = pred_g0_val + _track_per_record(ctx.val, r_val, lambda rec, x: _ema_causal(x, a))

    # simulation mode: a deterministic trend since the start of each record (offset and gain
    # drifting at constant rates); a drift that no input explains cannot be simulated beyond
    # that. Predictor mode (one step ahead, uses the measured output): the tracked drift state.
    pred, _ = ctx.fit_apply(_trend)
    ext = (
        "simulation: offset and gain drifting linearly from the start of each record; predictor: a drift "
        f"state tracked from the measured output (time constant {tau:.3g} s)"
    )
    return CauseResult(
        res,
        True,
        f"the residual has a slow trend over time ({_explained(res)})",
        ext,
        pred,
        {"predictor_val": pred_trk},
        Z_est=_trend_blocks(ctx, n_terms),
    )


def _drift_beyond_state(ctx: Context, alpha: float, f_res: stats.StatResult) -> CauseResult:
    """drift for records that carry their recording state: the test of :func:`_state_drift_test`;
    the extension a common R0 drift rate beyond each record's drift state (its drift column, the
    simulator's form rate t / 60 (1 + dR / 100)), fitted on estimation with the states beside it
    (each validation record's state refitted after it). Its gain is that of this simulation
    against the corrected simulation: the baseline's validation states are already refitted on
    the whole validation record, so a drift tracked from the measured output adds nothing to
    them (the causal rate fitted on the samples up to the previous one: paired t of -0.07..+1.24
    on the drift trials of tests/diagnose/test_diagnose_sim.py)."""
    res = _state_drift_test(ctx, alpha)
    res.detail["trend_f"] = f_res.value
    pred, _ = ctx.fit_apply(_drift_column)
    rates = ", ".join(f"{x:+.2f}" for x in res.detail["rate_pct_per_min"])
    return CauseResult(
        res,
        True,
        f"the records' R0 drifts beyond what repeats differ by (rates {rates} % of R0 per minute, common "
        f"{res.detail['common_pct_per_min']:+.2f} +- {res.detail['common_se_pct_per_min']:.2f}, 99 % prior bound "
        f"{res.detail['bound_pct_per_min'][0]:.2f})",
        "simulation: an R0 drift rate beyond each record's state, common to the records (rate t / 60 "
        "(1 + dR / 100)); predictor: the same, each record's state refitted on it",
        pred,
        {"predictor_val": pred},
        Z_est=ctx.stack(_drift_column, ctx.est),
    )


def periodic_disturbance(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a periodic disturbance of the measurement.

    Test: the strongest spectral line of the estimation residual (Hz) outside the inputs' own
    lines. Extension: a sine and cosine at that frequency, refined on each record's time axis (s),
    amplitude and phase free in every record (output units)."""
    exclude = None
    for i in range(ctx.n_in):
        m = stats.line_mask(ctx.u_est[:, i])
        exclude = m if exclude is None else exclude | m
    line = stats.spectral_lines(ctx.e_est, ctx.ts, alpha, exclude=exclude)
    f0 = line.detail["freq_hz"]
    n = len(ctx.e_est)
    # refine the frequency on each record's own time axis (records have their own phases)
    e_parts = np.split(ctx.e_est, np.cumsum(ctx.seg_est)[:-1])
    best = (-1.0, f0)
    for f in f0 + np.linspace(-1.0, 1.0, 41) / (n * ctx.ts):
        if f <= 0:
            continue
        amp = 0.0
        for r, e in zip(ctx.est, e_parts):
            amp += (e @ np.cos(2 * np.pi * f * r.t)) ** 2 + (e @ np.sin(2 * np.pi * f * r.t)) ** 2
        if amp > best[0]:
            best = (amp, f)
    f = best[1]

    def z(r):
        return np.column_stack([np.sin(2 * np.pi * f * r.t), np.cos(2 * np.pi * f * r.t)])

    # amplitude and phase free in every record
    blocks, start = [], 0
    for r in ctx.est:
        B = np.zeros((n, 2))
        B[start : start + len(r.y)] = z(r)
        blocks.append(B)
        start += len(r.y)
    test = ctx.f_test(np.column_stack(blocks))
    ftest = stats.f_result("F(residual ~ sinusoid)", test, alpha)
    res = stats.StatResult(
        line.name,
        line.value,
        line.threshold,
        line.p,
        alpha,
        {**line.detail, "f_test": ftest.value},
        log10_p=-min(line.strength, ftest.strength),
    )
    pred_g0_val, pred_g0_est = ctx.fit_apply(None)
    r_est = np.concatenate([r.y for r in ctx.est]) - pred_g0_est
    r_val = ctx.y_val - pred_g0_val

    def tracker(a):
        def fn(rec, x):
            c, s = np.cos(2 * np.pi * f * rec.t), np.sin(2 * np.pi * f * rec.t)
            return 2.0 * (_ema_causal(x * c, a) * c + _ema_causal(x * s, a) * s)

        return fn

    best = None
    for periods in (3.0, 10.0, 30.0):
        a = float(np.exp(-ctx.ts * f / periods))
        rss = float(np.sum((r_est - _track_per_record(ctx.est, r_est, tracker(a))) ** 2))
        if best is None or rss < best[0]:
            best = (rss, a, periods)
    pred_trk = pred_g0_val + _track_per_record(ctx.val, r_val, tracker(best[1]))
    # simulation mode: the sinusoid fitted on estimation continues with its phase from each
    # record's start (a disturbance not locked to the record start does not carry over)
    pred, _ = ctx.fit_apply(z)
    return CauseResult(
        res,
        line.significant,
        f"the residual has a spectral line at {f:.4g} Hz that the input does not have",
        f"simulation: a sinusoid at {f:.4g} Hz; predictor: the sinusoid's amplitude "
        "and phase tracked from the measured output",
        pred,
        {"freq_hz": f, "predictor_val": pred_trk},
        Z_est=np.column_stack(blocks),
        n_search=int(line.detail.get("tested", 1)),
    )


def _ar_one_step(r: np.ndarray, ar: np.ndarray, band: float | None = None):
    """One-step predictions of the residual r (output units) by its AR polynomial ``ar``.

    ``ar`` is [1, a1, ..., ap] (:func:`..signals.fit_ar`).
    With ``band`` (output units; robust: an additive-outlier filter), a sample whose innovation
    exceeds the band is taken for a glitch: the predictor's history holds the prediction plus the
    innovation clipped at the band, so the glitch does not carry into the next predictions.
    Returns (predictions, flagged samples)."""
    phi = -np.asarray(ar[1:], float)
    p = len(phi)
    n = len(r)
    hist = np.zeros(p)  # the record starts at the corrected model (residual 0)
    pred = np.zeros(n)
    flag = np.zeros(n, bool)
    for k in range(n):
        pk = float(phi @ hist) if p else 0.0
        pred[k] = pk
        x = r[k]
        if band is not None and abs(x - pk) > band:
            flag[k] = True
            x = pk + np.sign(x - pk) * band  # the innovation clipped at the band (no lock-out)
        if p:
            hist[1:] = hist[:-1]
            hist[0] = x
    return pred, flag


def outliers(ctx: Context, alpha: float) -> CauseResult:
    """Glitches: samples that leave the residual and return, beyond what its own dynamics predict.

    Test: :func:`..stats.isolated_spikes` of the estimation residual (each record whitened on its
    own), family-wise at alpha. Extension: the correction refit robustly on estimation with the
    flagged samples left out (Huber), and a one-step predictor on it with an AR model of its
    estimation residual (flagged samples interpolated) that takes a sample whose innovation
    exceeds the estimation's alpha/N band for a glitch and holds in its place the prediction
    plus the innovation clipped at the band (a robust filter-cleaner with a Huber psi: a
    persistent change is followed at the band per sample, the filter is not locked out). Baseline: the corrected model (least squares over every sample) with the same
    AR predictor reading every sample. Both are scored on the validation samples the filter does
    not flag (a glitch is predictable by neither). A glitch pulls a least-squares fit and leaves
    a reading predictor wrong on the samples after it, so rejecting it gains; a real change of
    level that the band flags (a transient the model misses) persists, so rejecting it loses.
    With a white residual (AR order 0) the gain is the robust refit's alone.
    """
    step = max(stats.resolution(r.y) for r in ctx.est)
    spikes = stats.isolated_spikes(ctx.e_est, alpha, step, ctx.seg_est)
    mask, thr, _ = stats.spike_mask(ctx.e_est, alpha, step, ctx.seg_est)
    pred, pred_est = ctx.fit_apply(None, robust=True, mask_est=mask)
    # the predictor pair: each on its own simulation (the robust refit, the corrected model), one
    # AR model of the robust refit's estimation residual with the flagged samples interpolated
    base_val, _ = ctx.fit_apply(None)
    r_est = np.concatenate([r.y for r in ctx.est]) - pred_est
    clean = []
    for part, m in zip(np.split(r_est, np.cumsum(ctx.seg_est)[:-1]), np.split(mask, np.cumsum(ctx.seg_est)[:-1])):
        idx = np.arange(len(part))
        clean.append(np.interp(idx, idx[~m], part[~m]) - np.mean(part[~m]) if (~m).sum() >= 2 else part * 0.0)
    ar = signals.fit_ar(np.concatenate(clean), 10)
    seg_val = [len(r.y) for r in ctx.val]
    reading, robust, flagged = [], [], []
    cuts = np.cumsum(seg_val)[:-1]
    for rb, rr in zip(np.split(ctx.y_val - base_val, cuts), np.split(ctx.y_val - pred, cuts)):
        reading.append(_ar_one_step(rb, ar)[0])
        pr, fl = _ar_one_step(rr, ar, thr if np.isfinite(thr) else None)
        robust.append(pr)
        flagged.append(fl)
    flagged = np.concatenate(flagged)
    idx = np.flatnonzero(mask)
    Z = np.zeros((len(ctx.e_est), len(idx)))
    Z[idx, np.arange(len(idx))] = 1.0
    kurt = spikes.detail["kurtosis"]
    res_note = f"; measurement resolution {step:.3g} allowed for" if step > 0 else ""
    return CauseResult(
        spikes,
        spikes.significant,
        f"{int(spikes.value)} isolated spikes "
        f"({100 * spikes.detail['fraction']:.2f} % of samples; excess kurtosis of the residual "
        f"differences {kurt:.3g}; {int(flagged.sum())} validation samples rejected{res_note})",
        "simulation: outlier rejection (alpha/N band) and a robust (Huber) refit; predictor: a one-step "
        "predictor that rejects glitches, against the same predictor reading every sample",
        pred,
        {
            "score_mask": ~flagged,
            "predictor_val": pred + np.concatenate(robust),
            "predictor_base_val": base_val + np.concatenate(reading),
        },
        Z_est=Z,
        n_search=1,
    )
