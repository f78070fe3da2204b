"""``resid``: residual correlation tests of a model on data, as MATLAB's ``resid`` draws them.

The residual e = y - yhat is the model simulated from rest (the one fit's simulation, see
:mod:`porosense.ident.scoring`). A model that captures the system leaves residuals that are

- white: their autocorrelation r_ee(k), k = 1..L, is zero but for sampling scatter. Tested with the
  Ljung-Box statistic Q = N (N + 2) sum r_ee(k)^2 / (N - k) against chi-square(L) at 1 %; the band
  drawn is +-2.576 / sqrt(N) (99 % per lag);
- independent of the inputs: the cross-correlation r_ue(k), k = -L..L, is zero but for scatter. A
  coloured input (the paper's steps and staircases are very coloured) makes neighbouring lags move
  together, so the input is first prewhitened by its own AR(10) model, e(t) is left as it is, and the
  lags' covariance under independence is C_kl = (1/N) sum_m r_uu(m) r_ee(m + k - l) (Bartlett, with
  the prewhitened input's r_uu, close to a unit impulse, which keeps C well conditioned);
  r_ue^T C^-1 r_ue is compared with chi-square(2L + 1) at 1 %, and the band drawn is +-2.576
  standard deviations of each lag.

A model with process noise or one fitted for simulation (output error) can leave coloured residuals
and still be the right model for its use; ``independent`` is then the test that matters (an
output-error model's residuals should not correlate with its inputs).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

LAGS = 25  # MATLAB resid's default number of lags
PREWHITEN_ORDER = 10  # AR order of the input's prewhitening filter
SIGNIFICANCE = 0.01
Z_99 = 2.5758293035489  # two-sided 99 % normal quantile


def _xcorr(a, b, lags: int) -> np.ndarray:
    """Normalised cross-correlation sum a(t) b(t + k) / sqrt(sum a^2 sum b^2), k = -lags..lags (by FFT)."""
    n = len(a)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    full = np.fft.irfft(np.conj(np.fft.rfft(a, size)) * np.fft.rfft(b, size), size)
    den = np.sqrt(np.sum(a * a) * np.sum(b * b)) or 1.0
    lags = min(lags, n - 1)
    return np.concatenate([full[size - lags :], full[: lags + 1]]) / den


def _independence(r_ue, r_uu_long, r_ee_long, lags: int, n: int) -> tuple[float, np.ndarray]:
    """(p-value, per-lag standard deviation) of the cross-correlation under independence.

    Under independence the lags of r_ue are jointly normal with covariance
    C_kl = (1/N) sum_m r_uu(m) r_ee(m + k - l) (Bartlett); r^T C^+ r is chi-square with rank(C)
    degrees of freedom. (A coloured input makes neighbouring lags move together: summing their
    squares as if they were independent would raise false alarms far above 1 %.)"""
    from scipy.stats import chi2

    m_max = (len(r_uu_long) - 1) // 2
    e_mid = (len(r_ee_long) - 1) // 2
    m = np.arange(-m_max, m_max + 1)
    d = np.arange(-2 * lags, 2 * lags + 1)
    # c(d) = (1/N) sum_m r_uu(m) r_ee(m + d) for every lag difference d
    c = np.array([np.sum(r_uu_long * r_ee_long[e_mid + m + dd]) for dd in d]) / n
    idx = np.arange(2 * lags + 1)
    cov = c[(idx[:, None] - idx[None, :]) + 2 * lags]
    cov = 0.5 * (cov + cov.T)
    w, v = np.linalg.eigh(cov)
    keep = w > 1e-6 * max(w.max(), 1e-300)
    proj = v[:, keep].T @ r_ue
    q = float(np.sum(proj**2 / w[keep]))
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    return float(chi2.sf(q, int(np.sum(keep)))), sd


def _prewhiten(x: np.ndarray) -> np.ndarray:
    """``x`` through the inverse of its AR(PREWHITEN_ORDER) model (Yule-Walker): nearly white."""
    from scipy.linalg import solve_toeplitz
    from scipy.signal import lfilter

    order = min(PREWHITEN_ORDER, len(x) // 10)
    r = _xcorr(x, x, order)[order:]
    if order < 1 or r[0] <= 0:
        return x
    try:
        a = solve_toeplitz(r[:order], r[1 : order + 1])
    except np.linalg.LinAlgError:
        return x
    return lfilter(np.concatenate([[1.0], -a]), [1.0], x)


@dataclass
class ResidResult:
    """Residual tests of one model on one data set (per output; inputs in the model's order)."""

    outputs: list
    inputs: list
    samples: int
    lags: np.ndarray  # 0..L
    autocorrelation: np.ndarray  # (n_y, L + 1)
    cross_lags: np.ndarray  # -L..L
    cross_correlation: np.ndarray  # (n_y, n_u, 2L + 1)
    cross_band: np.ndarray  # (n_y, n_u, 2L + 1): 99 % band of each lag
    whiteness_p: np.ndarray  # (n_y,)
    independence_p: np.ndarray  # (n_y, n_u)
    residuals: np.ndarray | None = field(repr=False, default=None)  # (N, n_y), output units

    @property
    def band(self) -> float:
        """The 99 % band of each autocorrelation lag, +-2.576 / sqrt(N)."""
        return Z_99 / np.sqrt(self.samples)

    @property
    def white(self) -> list:
        """Per output: the residuals pass the whiteness test at 1 %."""
        return [bool(p >= SIGNIFICANCE) for p in self.whiteness_p]

    @property
    def independent(self) -> list:
        """Per output: the residuals pass the independence test against every input at 1 %."""
        return [bool(np.all(p >= SIGNIFICANCE)) for p in self.independence_p]

    def lines(self) -> list:
        out = []
        for j, name in enumerate(self.outputs):
            w = "white" if self.white[j] else "not white"
            out.append(
                f"{name}: residuals {w} (Ljung-Box p = {self.whiteness_p[j]:.3g} over {len(self.lags) - 1} lags, "
                f"1 % level)"
            )
            for i, inp in enumerate(self.inputs):
                ok = "independent of" if self.independence_p[j, i] >= SIGNIFICANCE else "correlated with"
                out.append(
                    f"  {ok} {inp} (p = {self.independence_p[j, i]:.3g} over lags -{self.lags[-1]}..{self.lags[-1]})"
                )
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def to_dict(self) -> dict:
        return {
            "outputs": list(self.outputs),
            "inputs": list(self.inputs),
            "samples": self.samples,
            "lags": self.lags.tolist(),
            "autocorrelation": self.autocorrelation.tolist(),
            "band": self.band,
            "cross_lags": self.cross_lags.tolist(),
            "cross_correlation": self.cross_correlation.tolist(),
            "cross_band": self.cross_band.tolist(),
            "whiteness_p": self.whiteness_p.tolist(),
            "independence_p": self.independence_p.tolist(),
            "white": self.white,
            "independent": self.independent,
        }

    def plot(self, path=None):
        """MATLAB's resid figure: per output, the residual autocorrelation and the input-residual
        cross-correlations with their 99 % bands; returns the figure."""
        import matplotlib.pyplot as plt

        n_y, n_u = len(self.outputs), len(self.inputs)
        fig, axes = plt.subplots(n_y, 1 + n_u, figsize=(4 * (1 + n_u), 3 * n_y), squeeze=False)
        for j, out in enumerate(self.outputs):
            ax = axes[j, 0]
            ax.stem(self.lags, self.autocorrelation[j], basefmt=" ", label="r_ee")
            ax.fill_between(self.lags, -self.band, self.band, color="0.85", label="99 % band")
            ax.set_title(f"autocorrelation of the residuals of {out} ({'white' if self.white[j] else 'not white'})")
            ax.set_xlabel("lag (samples)")
            ax.set_ylabel("correlation (1)")
            ax.legend(fontsize="small")
            for i, inp in enumerate(self.inputs):
                ax = axes[j, 1 + i]
                ax.stem(self.cross_lags, self.cross_correlation[j, i], basefmt=" ", label="r_ue")
                band = self.cross_band[j, i]
                ax.fill_between(self.cross_lags, -band, band, color="0.85", label="99 % band")
                verdict = "independent" if self.independence_p[j, i] >= SIGNIFICANCE else "correlated"
                ax.set_title(f"prewhitened {inp} against the residuals of {out} ({verdict})")
                ax.set_xlabel("lag (samples)")
                ax.set_ylabel("correlation (1)")
                ax.legend(fontsize="small")
        fig.tight_layout()
        if path is not None:
            from porosense.files import save_figure

            save_figure(fig, path, dpi=110)
        return fig


def residual_tests(u, e, *, inputs=None, outputs=None, lags: int = LAGS) -> ResidResult:
    """Correlation tests of residuals ``e`` (N, n_y) against inputs ``u`` (N, n_u); see the module note."""
    from scipy.stats import chi2

    u = np.asarray(u, float).reshape(len(u), -1)
    e = np.asarray(e, float).reshape(len(e), -1)
    n = len(e)
    lags = int(min(lags, n // 4))
    if lags < 1:
        from porosense.errors import InputError

        raise InputError(f"{n} samples: too few for residual correlation tests")
    inputs = list(inputs) if inputs is not None else [f"u{k + 1}" for k in range(u.shape[1])]
    outputs = list(outputs) if outputs is not None else [f"y{k + 1}" for k in range(e.shape[1])]
    k = np.arange(lags + 1)
    auto = np.empty((e.shape[1], lags + 1))
    cross = np.empty((e.shape[1], u.shape[1], 2 * lags + 1))
    band = np.empty_like(cross)
    white_p = np.empty(e.shape[1])
    indep_p = np.empty((e.shape[1], u.shape[1]))
    for j in range(e.shape[1]):
        ej = e[:, j] - e[:, j].mean()
        r_ee = _xcorr(ej, ej, lags)
        auto[j] = r_ee[lags:]
        q = n * (n + 2) * np.sum(auto[j, 1:] ** 2 / (n - k[1:]))
        white_p[j] = float(chi2.sf(q, lags))
        r_ee_long = _xcorr(ej, ej, 4 * lags)
        for i in range(u.shape[1]):
            ui = _prewhiten(u[:, i] - u[:, i].mean())
            cross[j, i] = _xcorr(ui, ej, lags)
            indep_p[j, i], sd = _independence(cross[j, i], _xcorr(ui, ui, 2 * lags), r_ee_long, lags, n)
            band[j, i] = Z_99 * sd
    return ResidResult(outputs, inputs, n, k, auto, np.arange(-lags, lags + 1), cross, band, white_p, indep_p, e)
