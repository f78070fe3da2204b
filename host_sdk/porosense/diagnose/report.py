"""Figures and a Markdown summary of a :class:`porosense.diagnose.Diagnosis`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.files import save_figure, write_text


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def write_figures(diag, directory, unit: str = "output unit") -> list:
    """Correlations with bands, residual vs level and direction, spectrum, before/after fits (PNG).

    ``unit`` is the output's unit, written on every axis that carries it.
    """
    plt = _plt()
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    tests, cv = diag.residual_tests, diag.curves
    paths = []

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    ac = tests["autocorrelation"].detail
    axes[0].stem(ac["lags"], ac["r"])
    for s in (1, -1):
        axes[0].axhline(s * ac["band"], color="r", ls="--", lw=1)
    axes[0].set(title="residual autocorrelation", xlabel="lag (samples)", ylabel="r_ee (normalised, 1)")
    for key, t in tests.items():
        if key.startswith("crosscorrelation"):
            axes[1].plot(t.detail["lags"], t.detail["r"], ".-", label=key.split("_")[-1])
            band = t.detail["band"]
    axes[1].axhline(band, color="r", ls="--", lw=1)
    axes[1].axhline(-band, color="r", ls="--", lw=1)
    axes[1].set(
        title="input-residual cross-correlation (input prewhitened)",
        xlabel="lag (samples)",
        ylabel="r_ue (normalised, 1)",
    )
    axes[1].legend()
    fig.tight_layout()
    paths.append(d / "correlations.png")
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4))
    yh, e = cv["yhat_est"], cv["e_est"]
    rising = np.concatenate([[True], np.diff(yh) >= 0])
    ax.plot(yh[rising], e[rising], ".", ms=2, label="rising")
    ax.plot(yh[~rising], e[~rising], ".", ms=2, label="falling")
    ax.set(
        title="residual versus model output level and direction",
        xlabel=f"model output ({unit})",
        ylabel=f"residual ({unit})",
    )
    ax.legend()
    fig.tight_layout()
    paths.append(d / "level_direction.png")
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)

    sp = cv["spectrum"]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogy(sp["freqs"][1:], np.asarray(sp["power"])[1:] + 1e-300, lw=0.8)
    if cv.get("spectrum_significant", False):
        ax.axvline(sp["freq_hz"], color="r", ls="--", lw=1, label=f"significant line {sp['freq_hz']:.3g} Hz")
        ax.legend()
        title = "residual spectrum (Hann periodogram)"
    else:
        title = "residual spectrum (Hann periodogram): no significant line"
    ax.set(title=title, xlabel="frequency (Hz)", ylabel=f"power (({unit})²/Hz)")
    fig.tight_layout()
    paths.append(d / "spectrum.png")
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(10, 4))
    t = np.arange(len(cv["y_val"])) * cv["ts"]
    ax.plot(t, cv["y_val"], "k", lw=0.8, label="measured")
    from porosense.dsp.metrics import fit_percent

    ax.plot(t, cv["yhat_val"], lw=0.8, label=f"nominal model (fit {fit_percent(cv['y_val'], cv['yhat_val']):.1f} %)")
    shown = [f for f in diag.findings if f.cause in cv["extended_val"]][:2]
    for f in shown:
        ax.plot(t, cv["extended_val"][f.cause], lw=0.8, label=f"with {f.cause} ({f.fit_after:.1f} %)")
    ax.set(title="validation: before and after the extension", xlabel="time (s)", ylabel=f"output ({unit})")
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(d / "fits.png")
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)
    return paths


def summary_markdown(diag, title: str = "Diagnosis") -> str:
    """Short Markdown: verdict, the ranked table, evidence of the leading findings, figures."""
    lines = [f"# {title}", ""]
    for fit in (diag.nominal, diag.corrected):
        if fit is not None:
            lines.append(f"- {fit.what}: fit {fit.fit:.2f} %, RMS {fit.rms:.2f} %")
    if diag.dynamics.get("sentence"):
        lines.append(f"- dynamics: {diag.dynamics['sentence']}")
    lines += [
        "",
        f"**Most likely cause: {diag.top}**" + (f" ({diag.why_top})" if diag.why_top else ""),
        "",
        "| cause | found | against | fit before % | fit after % | gain (points) | t | parameters | statistic |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for f in diag.findings:
        lines.append(
            f"| {f.cause} | {'yes' if f.found else 'no'} | {f.baseline} | {f.fit_before:.2f} | {f.fit_after:.2f} | "
            f"{f.gain:+.2f} | {f.gain_t:.3g} | {f.n_params} | {f.statistic} |"
        )
    lines += ["", "## Evidence", ""]
    for f in diag.findings[:3]:
        lines.append(f"- **{f.cause}**: {f.evidence}")
    lines += ["", "## Residual tests", ""]
    for name, t in diag.residual_tests.items():
        lines.append(f"- {name}: {t.sentence()}")
    lines += ["", "## Figures", ""]
    for name in ("correlations", "level_direction", "spectrum", "fits"):
        lines.append(f"![{name}]({name}.png)")
    return "\n".join(lines) + "\n"


def write_report(diag, directory, title: str = "Diagnosis", unit: str = "output unit") -> Path:
    """Figures and ``summary.md`` in ``directory``; returns the summary's path. ``unit``: the output's."""
    d = Path(directory)
    write_figures(diag, d, unit)
    path = d / "summary.md"
    write_text(path, summary_markdown(diag, title))
    return path
