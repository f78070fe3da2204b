"""Figures this field expects, as plain functions: arrays in, a matplotlib Figure out.

Every function takes an optional ``path``: when given, the figure is saved there as PNG and
closed. Units are the caller's column units, passed in the labels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

# A fixed colour per model structure so every figure of a report agrees.
STRUCTURE_COLOURS = {"linear": "#7f7f7f", "hammerstein": "#1f77b4", "wiener": "#2ca02c", "wh": "#d62728"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(fig, path):
    if path is not None:
        fig.savefig(Path(path), dpi=110)
        _plt().close(fig)
    return fig


def plot_reconstruction(t, measured, estimates: dict, *, ylabel: str = "strain (%)", title: str = "", path=None):
    """Measured output against each model's estimate over time (s), like the paper's
    reconstruction figures. ``estimates`` maps a model name to its simulated output."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 3.6), layout="constrained")
    ax.plot(t, measured, color="black", lw=1.6, label="measured")
    for name, yhat in estimates.items():
        ax.plot(t, yhat, lw=1.1, color=STRUCTURE_COLOURS.get(name), label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(ncol=min(5, 1 + len(estimates)), fontsize=8, loc="best")
    return _finish(fig, path)


def plot_hysteresis(dR_pct, output, *, ylabel: str = "strain (%)", title: str = "", path=None):
    """dR (%) against the output: the loop whose area shows hysteresis and relaxation."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 4.2), layout="constrained")
    dR_pct = np.asarray(dR_pct)
    sc = ax.scatter(dR_pct, output, c=np.arange(len(dR_pct)), s=2, cmap="viridis")
    ax.plot(dR_pct, output, lw=0.3, color="grey", alpha=0.5)
    fig.colorbar(sc, ax=ax, label="sample")
    ax.set_xlabel("dR (%)")
    ax.set_ylabel(ylabel)
    ax.set_title(title or "dR versus output")
    ax.grid(alpha=0.3)
    return _finish(fig, path)


def plot_fit_bars(fits: dict, *, metric: str = "fit (%)", title: str = "", path=None):
    """Grouped bars: ``fits[structure][dataset] = value``; the paper's fit bar chart."""
    plt = _plt()
    structures = list(fits)
    datasets = list(next(iter(fits.values())))
    x = np.arange(len(datasets))
    width = 0.8 / max(1, len(structures))
    fig, ax = plt.subplots(figsize=(max(6, 1.3 * len(datasets) + 2), 3.8), layout="constrained")
    for k, s in enumerate(structures):
        vals = [fits[s].get(d, np.nan) for d in datasets]
        ax.bar(x + (k - (len(structures) - 1) / 2) * width, vals, width, label=s, color=STRUCTURE_COLOURS.get(s))
    ax.set_xticks(x, datasets, rotation=20)
    ax.set_ylabel(metric)
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=len(structures))
    return _finish(fig, path)


def plot_power_law(porosity_pct, values: dict, fits: dict | None = None, *, title: str = "", path=None):
    """Values against porosity (%) with fitted p = C (1 - phi/100)^n curves.

    ``values[label] = array`` per porosity; ``fits[label] = (C, n, r2)``.
    """
    plt = _plt()
    phi = np.asarray(porosity_pct, dtype=float)
    fig, axes = plt.subplots(1, len(values), figsize=(4.4 * len(values), 3.6), layout="constrained", squeeze=False)
    grid = np.linspace(phi.min() - 3, phi.max() + 3, 100)
    for ax, (label, v) in zip(axes[0], values.items()):
        ax.plot(phi, v, "o", color="black")
        if fits and label in fits:
            c, n, r2 = fits[label]
            ax.plot(grid, c * (1 - grid / 100) ** n, color="#d62728",
                    label=f"{c:.3g} (1 - phi/100)^{n:.2f}, R^2 {r2:.2f}")
            ax.legend(fontsize=8)
        ax.set_xlabel("porosity (%)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle(title or "porosity power law")
    return _finish(fig, path)


def fit_power_law(porosity_pct, values) -> tuple[float, float, float]:
    """Fit p = C (1 - phi/100)^n by least squares on the values; returns (C, n, R^2)."""
    from scipy import optimize

    phi = np.asarray(porosity_pct, dtype=float)
    v = np.asarray(values, dtype=float)
    base = 1 - phi / 100

    def resid(p):
        return p[0] * base ** p[1] - v

    logfit = np.polyfit(np.log(base), np.log(np.abs(v)), 1)
    c0 = np.sign(v.mean()) * np.exp(logfit[1])
    sol = optimize.least_squares(resid, [c0, logfit[0]])
    ss_res = float(np.sum(sol.fun**2))
    ss_tot = float(np.sum((v - v.mean()) ** 2))
    return float(sol.x[0]), float(sol.x[1]), 1 - ss_res / ss_tot if ss_tot > 0 else 1.0
