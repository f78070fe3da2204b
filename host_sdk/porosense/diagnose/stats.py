"""Residual statistics on plain arrays, each with its statistic and a false-alarm controlled threshold.

Residuals of a simulation are strongly autocorrelated, so no test here treats samples as
independent:

* correlation tests use bands from Bartlett's formula, var r_xy = (1/N) sum_k rho_x(k) rho_y(k),
  or prewhiten one of the two signals (Box-Jenkins) so that the band is 1/sqrt(N);
* dependence tests (residual against level, direction, trend, a column) are F tests in a
  feasible generalised least squares: the residual's AR noise model is estimated after the
  candidate regressors are removed, then residual and regressors are filtered by it;
* the number of lags or frequencies tested is corrected for (Bonferroni).

Every test returns a :class:`StatResult` whose ``p`` is the family-wise p-value of the test
and ``significant`` compares it with the test's ``alpha`` (per test, default 1 %).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import stats as sps

from porosense.diagnose import signals

DEFAULT_ALPHA = 0.01


@dataclass
class StatResult:
    """One residual test: name of the statistic, its value, the threshold at level ``alpha``."""

    name: str
    value: float
    threshold: float
    p: float
    alpha: float = DEFAULT_ALPHA
    detail: dict = field(default_factory=dict)
    log10_p: float | None = None  # exact log10 p when p underflows

    @property
    def significant(self) -> bool:
        return bool(self.strength > -np.log10(self.alpha))

    @property
    def strength(self) -> float:
        """-log10 p: how far beyond chance the statistic is (kept beyond double precision)."""
        if self.log10_p is not None:
            return float(-self.log10_p)
        return float(-np.log10(max(self.p, 1e-300)))

    def sentence(self) -> str:
        """``name = value (threshold t at alpha a %, p = ...)``."""
        return (
            f"{self.name} = {self.value:.3g} (threshold {self.threshold:.3g} at "
            f"{100 * self.alpha:g} % false alarm, p = {self.p:.2g})"
        )

    def to_dict(self) -> dict:
        d = asdict(self)
        d["significant"] = self.significant
        return d


def _zcrit(alpha: float, n_tests: int) -> float:
    """Two-sided normal quantile for a family of n_tests at family-wise level alpha."""
    return float(sps.norm.isf(alpha / (2.0 * max(n_tests, 1))))


def _p_from_max_z(zmax: float, n_tests: int) -> float:
    return float(min(1.0, 2.0 * n_tests * sps.norm.sf(abs(zmax))))


def residual_autocorrelation(e: np.ndarray, max_lag: int = 25, alpha: float = DEFAULT_ALPHA) -> StatResult:
    """Whiteness of the residual: max over lags 1..max_lag of |r_ee(k)| sqrt(N), Bonferroni.

    Under a correct model with white measurement noise r_ee(k) ~ N(0, 1/N).
    """
    e = np.asarray(e, float)
    n = len(e)
    r = signals.autocorr(e, max_lag)
    z = np.abs(r[1:]) * np.sqrt(n)
    k = int(np.argmax(z)) + 1
    return StatResult(
        "max |r_ee(k)| sqrt(N)",
        float(z.max()),
        _zcrit(alpha, max_lag),
        _p_from_max_z(z.max(), max_lag),
        alpha,
        {
            "lags": list(range(max_lag + 1)),
            "r": r.tolist(),
            "band": _zcrit(alpha, max_lag) / np.sqrt(n),
            "worst_lag": k,
        },
    )


def input_crosscorrelation(u: np.ndarray, e: np.ndarray, max_lag: int = 25, alpha: float = DEFAULT_ALPHA) -> StatResult:
    """Residual-input cross-correlation with the input prewhitened (Box-Jenkins).

    The input's AR model whitens u; the same filter is applied to e, so under independence
    the correlation at every lag is N(0, 1/N) whatever the input's colour. Positive lags
    (residual after input) mean unmodelled input dynamics; the lag of the largest positive-lag
    peak estimates a missing delay.
    """
    ar = signals.fit_ar(u, 10)
    uw = signals.whiten(u, ar)
    ew = signals.whiten(e, ar)
    n = len(uw)
    lags, r = signals.crosscorr(uw, ew, max_lag)
    z = np.abs(r) * np.sqrt(n)
    m = len(lags)
    pos = lags >= 0
    peak = int(lags[pos][np.argmax(z[pos])])
    return StatResult(
        "max |r_ue(tau)| sqrt(N), input prewhitened",
        float(z.max()),
        _zcrit(alpha, m),
        _p_from_max_z(z.max(), m),
        alpha,
        {
            "lags": lags.tolist(),
            "r": r.tolist(),
            "band": _zcrit(alpha, m) / np.sqrt(n),
            "peak_lag": peak,
            "positive_lag_share": float(np.sum(r[pos] ** 2) / max(np.sum(r**2), 1e-300)),
        },
    )


@dataclass
class Rises:
    """Lags (samples) at which the measured and the model's step responses to an input first reach
    ``RISE_SHARE`` of their largest magnitude over the lags examined."""

    measured: int
    model: int


RISE_SHARE = 0.1


def response_rises(u: np.ndarray, y: np.ndarray, yhat: np.ndarray, max_lag: int = 30) -> Rises:
    """Where the measured response to ``u`` rises, and where the model's does (a missing delay).

    The input is prewhitened by its AR model and the same filter is applied to y and yhat; the
    cross-correlation of the whitened input with the whitened output is proportional to the
    impulse response (Box-Jenkins), and its running sum to the step response. The rise lag is the
    first lag where that running sum reaches ``RISE_SHARE`` of its largest magnitude: a delay the
    model lacks makes the measured response rise later than the model's by the delay, also when
    the model has bent its dynamics to mimic it (its response then rises early and slowly).
    """
    ar = signals.fit_ar(u, 10)
    uw = signals.whiten(u, ar)

    def rise(z):
        lags, r = signals.crosscorr(uw, signals.whiten(np.asarray(z, float), ar), max_lag)
        step = np.cumsum(r[lags >= 0])
        peak = float(np.max(np.abs(step))) or 1.0
        return int(np.argmax(np.abs(step) >= RISE_SHARE * peak))

    return Rises(rise(y), rise(yhat))


def bartlett_crosscorrelation(x: np.ndarray, y: np.ndarray, lags: np.ndarray, alpha: float, name: str) -> StatResult:
    """corr(x[k], y[k + tau]) at ``lags`` with Bartlett's variance for two coloured signals."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = len(x)
    k = min(n - 1, 200)
    rx = signals.autocorr(x, k)
    ry = signals.autocorr(y, k)
    var = (1.0 + 2.0 * np.sum(rx[1:] * ry[1:])) / n
    var = max(var, 1.0 / n)
    all_lags, r = signals.crosscorr(x, y, int(np.max(np.abs(lags))))
    sel = np.isin(all_lags, lags)
    z = np.abs(r[sel]) / np.sqrt(var)
    m = int(sel.sum())
    return StatResult(
        name,
        float(z.max()),
        _zcrit(alpha, m),
        _p_from_max_z(z.max(), m),
        alpha,
        {"lags": all_lags[sel].tolist(), "r": r[sel].tolist(), "band": _zcrit(alpha, m) * np.sqrt(var)},
    )


def billings_voon(u: np.ndarray, e: np.ndarray, max_lag: int = 20, alpha: float = DEFAULT_ALPHA) -> dict:
    """Billings-Voon higher-order correlation tests for unmodelled nonlinearity.

    phi_{u2'e}(tau) = corr(u^2 - mean, e), phi_{u2'e2}(tau) = corr(u^2 - mean, e^2 - mean) for
    tau = 0..max_lag, and phi_{e(eu)}(tau) = corr(e[k], e[k-1-tau] u[k-1-tau]) for tau >= 0.
    A linear model of a linear system leaves all three inside the bands. Bartlett variance
    (coloured signals) and Bonferroni over lags and the three tests (alpha / 3 each).
    """
    u = (np.asarray(u, float) - np.mean(u)) / (np.std(u) or 1.0)
    e = (np.asarray(e, float) - np.mean(e)) / (np.std(e) or 1.0)
    lags = np.arange(0, max_lag + 1)
    u2 = u * u - np.mean(u * u)
    a = alpha / 3.0
    res = {
        "u2_e": bartlett_crosscorrelation(u2, e, lags, a, "max |phi_u2'e| / sd"),
        "u2_e2": bartlett_crosscorrelation(u2, e * e - np.mean(e * e), lags, a, "max |phi_u2'e2| / sd"),
    }
    eu = np.concatenate([[0.0], (e * u)[:-1]])  # e[k-1] u[k-1]
    res["e_eu"] = bartlett_crosscorrelation(eu, e, lags, a, "max |phi_e(eu)| / sd")
    return res


def lstsq(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least squares by the normal equations on unit-norm columns (small k, large N: fast).

    A relative ridge of 1e-10 keeps exactly collinear columns solvable; coefficients of
    collinear columns are then split, which changes neither fit nor residual.
    """
    X = np.asarray(X, float)
    if X.shape[1] == 0:
        return np.zeros(0)
    s = np.sqrt(np.einsum("ij,ij->j", X, X))
    s[s == 0] = 1.0
    Xs = X / s
    G = Xs.T @ Xs
    G[np.diag_indices_from(G)] += 1e-10 * max(np.trace(G), 1e-300) / len(G)
    try:
        c = np.linalg.solve(G, Xs.T @ y)
    except np.linalg.LinAlgError:
        c = np.linalg.lstsq(Xs, y, rcond=None)[0]
    return c / s


@dataclass
class FTest:
    """Result of :func:`gls_f_test` (F statistic, dof, p, variance share explained)."""

    f: float
    df1: int
    df2: int
    p: float
    explained: float
    ar_order: int
    coef: np.ndarray
    log10_p: float = 0.0


def gls_f_test(
    e: np.ndarray, Z: np.ndarray, base: np.ndarray | None = None, max_ar: int = 10, segments: list[int] | None = None
) -> FTest:
    """F test that the columns of Z explain e beyond the columns of ``base`` (feasible GLS).

    1. OLS of e on [base, Z]; 2. AR(p) noise model (BIC, p <= max_ar) of its residual;
    3. filter e, base and Z with the AR polynomial (per segment, start-up samples dropped);
    4. classical nested F test on the filtered data. The AR step makes the test honest for
    autocorrelated residuals; estimating it after removing Z keeps Z's effect out of it.
    ``explained`` is the share of the whitened residual sum of squares that Z removes.
    """
    e = np.asarray(e, float)
    n = len(e)
    Z = np.asarray(Z, float).reshape(n, -1)
    B = np.ones((n, 1)) if base is None else np.column_stack([np.ones(n), np.asarray(base, float).reshape(n, -1)])
    X = np.column_stack([B, Z])
    coef = lstsq(X, e)
    ar = signals.fit_ar(e - X @ coef, max_ar)
    segments = segments or [n]
    ew, Xw = [], []
    start = 0
    for length in segments:
        sl = slice(start, start + length)
        ew.append(signals.whiten(e[sl], ar))
        Xw.append(signals.whiten(X[sl], ar))
        start += length
    ew = np.concatenate(ew)
    Xw = np.vstack(Xw)
    nb = B.shape[1]
    # drop regressors that are numerically absent (e.g. constant hinge columns)
    scale = np.linalg.norm(Xw, axis=0)
    keep = scale > 1e-12 * max(scale.max(), 1e-300)
    keep[:nb] = True
    scale = np.where(scale > 0, scale, 1.0)
    Xw = Xw[:, keep] / scale[keep]
    kz = int(keep[nb:].sum())
    c0 = lstsq(Xw[:, :nb], ew)
    rss0 = float(np.sum((ew - Xw[:, :nb] @ c0) ** 2))
    c1 = lstsq(Xw, ew)
    rank = Xw.shape[1]  # collinear columns would overstate df1: conservative
    rss1 = float(np.sum((ew - Xw @ c1) ** 2))
    df1 = max(int(rank) - nb, 1) if kz else 1
    df2 = max(len(ew) - int(rank), 1)
    if kz == 0 or rss1 <= 0:
        f, p = 0.0, 1.0
    else:
        f = ((rss0 - rss1) / df1) / (rss1 / df2)
        p = float(sps.f.sf(f, df1, df2))
    logp = _f_log10_sf(f, df1, df2) if p < 1e-280 else (np.log10(p) if p > 0 else -300.0)
    return FTest(
        float(f),
        df1,
        df2,
        p,
        float((rss0 - rss1) / rss0) if rss0 > 0 else 0.0,
        len(ar) - 1,
        coef[nb:] if kz else np.zeros(0),
        float(logp),
    )


def _f_log10_sf(f: float, df1: int, df2: int) -> float:
    """log10 of the F survival function where it underflows (via the regularised beta tail)."""
    if f <= 0:
        return 0.0
    x = df2 / (df2 + df1 * f)
    # sf = I_x(df2/2, df1/2); for tiny x, I_x(a, b) ~ x^a (1-x)^b / (a B(a, b))
    a, b = df2 / 2.0, df1 / 2.0
    from scipy.special import betaln

    ln = a * np.log(x) + b * np.log1p(-x) - np.log(a) - betaln(a, b)
    return float(ln / np.log(10.0))


def f_result(name: str, test: FTest, alpha: float, n_tests: int = 1, **detail) -> StatResult:
    """Wrap an :class:`FTest` (Bonferroni over ``n_tests`` alternatives) as a StatResult."""
    p = min(1.0, test.p * n_tests)
    thr = float(sps.f.isf(alpha / n_tests, test.df1, test.df2))
    return StatResult(
        name,
        test.f,
        thr,
        max(p, 1e-300),
        alpha,
        {"df1": test.df1, "df2": test.df2, "explained": test.explained, "ar_order": test.ar_order, **detail},
        log10_p=min(0.0, test.log10_p + float(np.log10(n_tests))),
    )


def _line_ratios(x: np.ndarray, guard: int, half_width: int, min_bin: int):
    """Hann periodogram P and, per bin, P / mean of its neighbours and that mean's dof."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    P = np.abs(np.fft.rfft(x * np.hanning(n))) ** 2
    m = len(P)
    ratio = np.zeros(m)
    dof = np.zeros(m)
    for k in range(min_bin, m - 1):
        lo, hi = max(1, k - half_width), min(m, k + half_width + 1)
        idx = np.r_[lo : max(lo, k - guard), min(hi, k + guard + 1) : hi]
        if len(idx) < 8:
            continue
        ratio[k] = P[k] / (np.mean(P[idx]) + 1e-300)
        dof[k] = len(idx)  # Hann makes neighbours pairwise correlated: about len/2 independent chi2_2
    return P, ratio, dof


def spectral_lines(
    e: np.ndarray,
    ts: float,
    alpha: float = DEFAULT_ALPHA,
    guard: int = 3,
    half_width: int = 40,
    min_bin: int = 6,
    exclude: np.ndarray | None = None,
) -> StatResult:
    """Largest periodogram line of the residual against its local background (periodic disturbance).

    Hann-tapered periodogram; each ordinate is divided by the mean of its neighbours
    (+-half_width bins, minus +-guard bins around it). For a smooth noise spectrum the ordinate
    is Exp-distributed and the mean of its ~m/2 independent neighbours chi2 with m dof, so the
    ratio is F(2, m). The largest over M tested bins has p = M sf_F (Bonferroni). Bins below
    ``min_bin`` (trend) and bins flagged in ``exclude`` (lines the input has too: input-driven,
    not disturbances) are not tested.
    """
    n = len(e)
    P, ratio, dof = _line_ratios(e, guard, half_width, min_bin)
    freqs = np.fft.rfftfreq(n, ts)
    if exclude is not None:
        ratio[np.asarray(exclude, bool)[: len(ratio)]] = 0.0
    tested = max(int(np.sum(ratio > 0)), 1)
    logsf = np.where(ratio > 0, sps.f.logsf(ratio, 2, np.maximum(dof, 1)), 0.0)
    k = int(np.argmin(logsf))
    log10_p = min(0.0, (float(logsf[k]) + np.log(tested)) / np.log(10.0))
    thr = float(sps.f.isf(alpha / tested, 2, max(dof[k], 1))) if dof[k] > 0 else float("inf")
    return StatResult(
        "periodogram line / local background",
        float(ratio[k]),
        thr,
        max(10.0**log10_p, 1e-300),
        alpha,
        {"freq_hz": float(freqs[k]), "bin": k, "tested": tested, "freqs": freqs.tolist(), "power": P.tolist()},
        log10_p=log10_p,
    )


def line_mask(x: np.ndarray, alpha: float = 1e-3, guard: int = 3, half_width: int = 40) -> np.ndarray:
    """Boolean mask of periodogram bins (with +-guard neighbours) where ``x`` itself has a line."""
    P, ratio, dof = _line_ratios(x, guard, half_width, 1)
    m = len(P)
    mask = np.zeros(m, bool)
    ok = ratio > 0
    p = np.ones(m)
    p[ok] = sps.f.sf(ratio[ok], 2, dof[ok]) * max(int(ok.sum()), 1)
    for k in np.flatnonzero(p < alpha):
        mask[max(0, k - guard) : k + guard + 1] = True
    return mask


def limit_clustering(
    x: np.ndarray, alpha: float = DEFAULT_ALPHA, tol_frac: float = 1e-6, n_levels: int = 5
) -> StatResult:
    """Samples piled up at the smallest or largest value of x (clipping at an ADC/divider limit).

    k_at = samples within tol_frac * range of the extreme; k_ref = the largest count among the
    next ``n_levels`` distinct values inside it (quantisation levels, or single samples for a
    continuous signal). A signal thins out towards its extremes, so without clipping the extreme
    level holds no more samples than its neighbours; the p-value is the binomial tail
    P(K >= k_at | k_at + k_ref, 1/2) (two ends, Bonferroni). At least 10 samples at the limit
    are required.
    """
    x = np.asarray(x, float)
    span = float(np.ptp(x)) or 1.0
    best = None
    for side, ext in (("low", x.min()), ("high", x.max())):
        d = np.abs(x - ext)
        at = d <= tol_frac * span
        k_at = int(np.sum(at))
        values, counts = np.unique(np.round(d[~at] / (tol_frac * span)), return_counts=True)
        k_ref = int(counts[:n_levels].max()) if len(counts) else 0
        p = float(sps.binom.sf(k_at - 1, k_at + k_ref, 0.5)) * 2.0 if k_at >= 10 else 1.0
        p = min(1.0, p)
        if best is None or p < best[0]:
            best = (p, side, float(ext), k_at, k_ref)
    p, side, ext, k_at, k_ref = best
    return StatResult(
        "samples at the limit",
        float(k_at),
        10.0,
        max(p, 1e-300),
        alpha,
        {"side": side, "limit": ext, "k_at": k_at, "k_near": k_ref, "fraction": k_at / len(x)},
    )


def resolution(x: np.ndarray) -> float:
    """Quantisation step of x (0 for a continuous signal): the median gap between its distinct
    values when it takes fewer distinct values than a quarter of its samples (an ADC's LSB)."""
    x = np.asarray(x, float)
    levels = np.unique(x)
    if len(levels) < 2 or len(levels) > len(x) // 4:
        return 0.0
    return float(np.median(np.diff(levels)))


def spike_mask(e: np.ndarray, alpha: float = DEFAULT_ALPHA, step: float = 0.0, segments: list[int] | None = None):
    """(mask, threshold, sigma): samples of e whose innovation lies beyond the family-wise band.

    The residual is whitened by its own AR model (Yule-Walker, BIC order): an isolated spike in
    e is a spike of the innovation, while coloured noise and slow model errors are not. The
    innovation's robust SD sigma is 1.4826 MAD; a sample is flagged when its innovation exceeds
    z sigma + step_w, z the two-sided normal quantile at alpha / N (Bonferroni over the N
    samples: on Gaussian noise no sample is flagged with probability about 1 - alpha).
    ``step`` is the measurement's resolution: rounding moves each sample by at most step / 2,
    which the AR filter turns into at most step_w = step / 2 sum |a_j| in the innovation, so
    coarse ADC levels are not spikes.
    ``segments``: lengths of the records concatenated in e (None: one record). Each record is
    centred on its own mean and whitened on its own (its first p samples are not tested): the
    step between the end of one record and the start of the next is not a sample of either.
    """
    e = np.asarray(e, float)
    n = len(e)
    segments = list(segments or [n])
    if n < 20:
        return np.zeros(n, bool), np.inf, 0.0
    cuts = np.cumsum(segments)[:-1]
    parts = [x - np.mean(x) if len(x) else x for x in np.split(e, cuts)]
    ar = signals.fit_ar(np.concatenate(parts), 10)
    p = len(ar) - 1
    w = np.full(n, np.nan)
    start = 0
    for x in parts:
        if len(x) > p:
            w[start + p : start + len(x)] = signals.whiten(x, ar)
        start += len(x)
    tested = np.isfinite(w)
    d = w[tested] - np.median(w[tested])
    sigma = 1.4826 * float(np.median(np.abs(d)))
    if sigma <= 0:
        sigma = float(np.std(d)) or 1e-12
    thr = _zcrit(alpha, n) * sigma + 0.5 * step * float(np.sum(np.abs(ar)))
    mask = np.zeros(n, bool)
    mask[tested] = np.abs(d) > thr
    start = 0
    for x in parts:
        _keep_glitches(mask[start : start + len(x)], x, p)
        start += len(x)
    return mask, thr, sigma


def _keep_glitches(mask: np.ndarray, e: np.ndarray, p: int) -> None:
    """Keep (in place) the runs of flagged samples after which the residual returns: a glitch.

    A run of consecutive flagged samples (a glitch, a burst, and the innovations its AR
    memory of p samples leaves) is compared with the residual e over the max(p, 1) + 1 samples
    before and after it: the residual returns when its median after the run is closer to the
    median before it than the run's largest excursion is, i.e. the level after differs from the
    level before by less than half that excursion (the midpoint between "returned" and "stayed").
    A transient the model misses or a change of level does not return and is not a glitch. A run
    at a record's edge, with no samples on one side, is kept.
    """
    n = len(mask)
    h = max(p, 1) + 1
    k = 0
    while k < n:
        if not mask[k]:
            k += 1
            continue
        end = k
        while end + 1 < n and mask[end + 1]:
            end += 1
        before, after = e[max(0, k - h) : k], e[end + 1 : end + 1 + h]
        if len(before) and len(after):
            m0, m1 = float(np.median(before)), float(np.median(after))
            excursion = float(np.max(np.abs(e[k : end + 1] - m0)))
            if abs(m1 - m0) >= 0.5 * excursion:
                mask[k : end + 1] = False
        k = end + 1


def isolated_spikes(
    e: np.ndarray, alpha: float = DEFAULT_ALPHA, step: float = 0.0, segments: list[int] | None = None
) -> StatResult:
    """Count of isolated spikes in e beyond the family-wise band of :func:`spike_mask`.

    Under Gaussian noise each sample exceeds the band with probability q = alpha / N, so the
    count k has p = P(Binomial(N, q) >= k). The excess kurtosis of the differenced residual
    (within each record of ``segments``) is reported too.
    """
    e = np.asarray(e, float)
    n = len(e)
    mask, thr, sigma = spike_mask(e, alpha, step, segments)
    k = int(mask.sum())
    q = alpha / max(n, 1)
    p = float(sps.binom.sf(k - 1, n, q)) if k > 0 else 1.0
    logp = float(sps.binom.logsf(k - 1, n, q) / np.log(10.0)) if k > 0 else 0.0
    d = np.concatenate([np.diff(x) for x in np.split(e, np.cumsum(list(segments or [n]))[:-1])])
    kurt = float(sps.kurtosis(d)) if len(d) > 3 else 0.0
    return StatResult(
        "isolated spikes beyond the alpha/N band",
        float(k),
        1.0,
        max(p, 1e-300),
        alpha,
        {
            "kurtosis": kurt,
            "fraction": k / max(n, 1),
            "band": thr,
            "sigma": sigma,
            "step": step,
            "index": np.flatnonzero(mask)[:50].tolist(),
        },
        log10_p=min(logp, 0.0),
    )


def is_piecewise_constant(x: np.ndarray) -> bool:
    """True for command-like signals (more than half of the steps are exactly zero)."""
    x = np.asarray(x, float)
    return len(x) > 2 and float(np.mean(np.diff(x) == 0.0)) > 0.5


N_BATCHES = 20
CONFIRM_ALPHA = 0.05


@dataclass
class GainTest:
    """One-sided test that an extension's held-out squared error is below the baseline's.

    t: batch-means t statistic of the mean paired difference (baseline - extension) of squared
    errors (df = batches - 1); p: one-sided p value; confirmed: p < alpha.
    """

    t: float
    p: float
    df: int
    alpha: float

    @property
    def confirmed(self) -> bool:
        """The extension is better on held-out data (one-sided, level alpha)."""
        return bool(self.p < self.alpha)

    @property
    def refuted(self) -> bool:
        """The extension is worse on held-out data (one-sided, level alpha)."""
        return bool(self.df > 0 and sps.t.cdf(self.t, self.df) < self.alpha)

    def sentence(self) -> str:
        verdict = (
            "refuted (worse on held-out data)"
            if self.refuted
            else ("confirmed" if self.confirmed else "not distinguishable from zero")
        )
        return (
            f"held-out gain {verdict}: batch-means t = {self.t:.3g} on {self.df} df "
            f"(one-sided tests at {100 * self.alpha:g} %)"
        )


def paired_gain_test(
    y: np.ndarray, base: np.ndarray, ext: np.ndarray, alpha: float = CONFIRM_ALPHA, n_batches: int = N_BATCHES
) -> GainTest:
    """Is ``ext`` closer to ``y`` than ``base`` beyond the sampling uncertainty of the difference?

    d[k] = (y - base)^2 - (y - ext)^2 is serially correlated (both errors share the residual's
    colour), so its mean's standard error is estimated by batch means: the record is cut into
    ``n_batches`` contiguous batches, whose means are nearly independent when a batch is much
    longer than the correlation time; t = mean / (SD of batch means / sqrt(B)) with B - 1 df.
    A positive mean is a lower validation RMS, i.e. a positive fit gain.
    """
    d = (np.asarray(y, float) - base) ** 2 - (np.asarray(y, float) - ext) ** 2
    return mean_positive_test(d, alpha, n_batches)


def mean_positive_test(d: np.ndarray, alpha: float = CONFIRM_ALPHA, n_batches: int = N_BATCHES) -> GainTest:
    """One-sided batch-means t test that the serially correlated series ``d`` has a positive mean.

    Non-finite entries (samples left out) are dropped; the rest is cut into ``n_batches``
    contiguous batches whose means are nearly independent (t on batches - 1 df).
    """
    d = np.asarray(d, float)
    d = d[np.isfinite(d)]
    b = int(min(n_batches, len(d) // 10))
    if b < 3:
        return GainTest(0.0, 1.0, 0, alpha)
    means = np.array([p.mean() for p in np.array_split(d, b)])
    sd = float(np.std(means, ddof=1))
    if sd <= 0:
        t = np.inf if means.mean() > 0 else 0.0
    else:
        t = float(means.mean() / (sd / np.sqrt(b)))
    return GainTest(float(t), float(sps.t.sf(t, b - 1)), b - 1, alpha)


@dataclass
class ExcessTest:
    """One-sided test that a signal is positive on average over flagged samples (runs as groups)."""

    mean: float
    t: float
    p: float
    groups: int
    alpha: float = CONFIRM_ALPHA

    @property
    def confirmed(self) -> bool:
        return bool(self.p < self.alpha)


def mean_excess_test(x: np.ndarray, flagged: np.ndarray, alpha: float = CONFIRM_ALPHA) -> ExcessTest:
    """Is ``x`` positive on average over the ``flagged`` samples, beyond their own scatter?

    Flagged samples come in contiguous runs whose values are correlated, so the runs' means are
    the observations (t on runs - 1 df); with fewer than 3 runs, the flagged samples are cut into
    up to 20 contiguous batches instead (batch means, as :func:`paired_gain_test`).
    """
    x = np.asarray(x, float)
    flagged = np.asarray(flagged, bool)
    if not flagged.any():
        return ExcessTest(0.0, 0.0, 1.0, 0, alpha)
    edges = np.flatnonzero(np.diff(np.r_[0, flagged.astype(int), 0]))
    runs = [x[a:b] for a, b in zip(edges[::2], edges[1::2])]
    if len(runs) < 3:
        vals = x[flagged]
        runs = np.array_split(vals, int(min(N_BATCHES, max(len(vals) // 10, 1))))
    means = np.array([r.mean() for r in runs if len(r)])
    mean = float(np.mean(x[flagged]))
    if len(means) < 3:
        return ExcessTest(mean, 0.0, 1.0, len(means), alpha)
    sd = float(np.std(means, ddof=1))
    t = (
        np.inf
        if sd <= 0 and means.mean() > 0
        else (0.0 if sd <= 0 else float(means.mean() / (sd / np.sqrt(len(means)))))
    )
    return ExcessTest(mean, float(t), float(sps.t.sf(t, len(means) - 1)), len(means), alpha)
