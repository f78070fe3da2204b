"""Figures this field expects, as plain functions: arrays in, a matplotlib Figure out.

Every function takes an optional ``path``: when given, the figure is saved there as PNG and
closed. Units are the caller's column units, passed in the labels.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from porosense.dsp.metrics import fit_percent
from porosense.files import save_figure

# A fixed colour per model structure so every figure of a report agrees.
STRUCTURE_COLOURS = {"linear": "#7f7f7f", "hammerstein": "#1f77b4", "wiener": "#2ca02c", "wh": "#d62728"}


def model_colours(names) -> dict:
    """A colour per model name, the same in every figure: the structure's colour when every name
    maps to a different structure (by name or a '(kind)' suffix), else a fixed palette in order."""

    def kind(name):
        for k in sorted(STRUCTURE_COLOURS, key=len, reverse=True):
            if name == k or name.endswith(f"({k})") or name.startswith(f"{k} ") or name == f"{k}.json":
                return k
        return None

    names = list(names)
    kinds = [kind(n) for n in names]
    if all(kinds) and len(set(kinds)) == len(kinds):
        return {n: STRUCTURE_COLOURS[k] for n, k in zip(names, kinds)}
    palette = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"]
    return {n: palette[i % len(palette)] for i, n in enumerate(names)}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


from porosense.files import LABELS_KEY, figure_labels  # noqa: E402,F401  (the labels every PNG carries)


def _finish(fig, path):
    """Save as PNG, with the figure's labels and legends as JSON in a PNG text chunk (the report
    page shows them to browsers and tests), and close it."""
    if path is not None:
        save_figure(fig, Path(path), dpi=110)
        _plt().close(fig)
    return fig


def read_labels(path) -> dict:
    """The labels :func:`_finish` stored in the PNG at ``path`` ({} when it holds none)."""

    from PIL import Image

    try:
        with Image.open(path) as img:
            text = img.text.get(LABELS_KEY)
        return json.loads(text) if text else {}
    except (OSError, ValueError):
        return {}


def _legend_outside(ax, n_entries: int):
    """Legend to the right of the axes, never over the data."""
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
        fontsize=8,
        frameon=False,
        ncol=1 if n_entries <= 12 else 2,
    )


def plot_reconstruction(
    t, measured, estimates: dict, *, ylabel: str = "strain (%)", title: str = "", path=None, show_fit: bool = True
):
    """Measured output against each model's estimate over time (s), like the paper's
    reconstruction figures. ``estimates`` maps a model name to its simulated output; the
    legend (beside the axes) gives each model's NRMSE fit in %."""

    plt = _plt()
    fig, ax = plt.subplots(figsize=(9.5, 3.6), layout="constrained")
    ax.plot(t, measured, color="black", lw=1.6, label="measured")
    colours = model_colours(estimates)
    for name, yhat in estimates.items():
        label = f"{name} (fit {fit_percent(measured, yhat):.1f} %)" if show_fit else name
        ax.plot(t, yhat, lw=1.1, color=colours[name], label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    _legend_outside(ax, 1 + len(estimates))
    return _finish(fig, path)


def plot_compare(
    t, measured: dict, predicted: dict, *, label: str = "model", units: dict | None = None, title: str = "", path=None
):
    """MATLAB's ``compare``: one panel per output, measured (when known) and predicted against
    time (s), the fit (%) in the legend. ``measured``/``predicted`` map output names to arrays."""

    plt = _plt()
    names = list(predicted)
    fig, axes = plt.subplots(
        len(names), 1, figsize=(9.5, 2.6 * len(names) + 0.6), layout="constrained", squeeze=False, sharex=True
    )
    for ax, name in zip(axes[:, 0], names):
        if name in measured:
            ax.plot(t, measured[name], color="black", lw=1.5, label="measured")
            fit = fit_percent(measured[name], predicted[name])
            ax.plot(t, predicted[name], color="#d62728", lw=1.1, label=f"{label} (fit {fit:.1f} %)")
        else:
            ax.plot(t, predicted[name], color="#d62728", lw=1.1, label=label)
        from porosense.data.units import axis_label

        ax.set_ylabel(axis_label(name, units or {}))
        ax.grid(alpha=0.3)
        _legend_outside(ax, 2)
    axes[-1, 0].set_xlabel("time (s)")
    axes[0, 0].set_title(title)
    return _finish(fig, path)


def plot_hysteresis(
    dR_pct,
    output,
    *,
    ylabel: str = "strain (%)",
    title: str = "",
    path=None,
    colour=None,
    colour_label: str = "time (s)",
    fits: dict | None = None,
    xlabel: str = "dR (%)",
):
    """dR (%) against the output: the loop whose area shows hysteresis and relaxation.

    ``colour`` (time in s, or pressure in kPa) colours the points, ``colour_label`` names it
    with its unit; without it the points are coloured by sample index. ``fits`` maps a
    direction ("loading", "unloading") to (x, y) of a fitted curve drawn over the loop.
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.6, 4.2), layout="constrained")
    dR_pct = np.asarray(dR_pct)
    if colour is None:
        colour, colour_label = np.arange(len(dR_pct)), "sample"
    sc = ax.scatter(dR_pct, output, c=np.asarray(colour), s=2, cmap="viridis")
    ax.plot(dR_pct, output, lw=0.3, color="grey", alpha=0.5)
    fig.colorbar(sc, ax=ax, label=colour_label)
    for (direction, (x, y)), c in zip((fits or {}).items(), ("#d62728", "#1f77b4")):
        ax.plot(x, y, color=c, lw=2.0, label=f"{direction} fit")
    if fits:
        ax.legend(fontsize=8, loc="best")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title or "dR versus output")
    ax.grid(alpha=0.3)
    return _finish(fig, path)


def mean_and_se(values) -> tuple[float, float]:
    """Mean and standard error of the mean (sample std / sqrt(n); 0 for one value) of finite values."""
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    if v.size == 0:
        return float("nan"), float("nan")
    se = float(np.std(v, ddof=1) / np.sqrt(v.size)) if v.size > 1 else 0.0
    return float(v.mean()), se


def plot_fit_bars(fits: dict, *, metric: str = "fit (%)", title: str = "", path=None, xlabel: str = "dataset"):
    """Grouped bars: ``fits[model][dataset] = value``; the paper's fit bar chart.

    A last group "mean" shows each model's mean over the datasets with the standard error
    of the mean as an error bar.
    """
    plt = _plt()
    structures = list(fits)
    datasets = list(dict.fromkeys(d for s in structures for d in fits[s]))
    groups = datasets + ["mean ± SE"]
    x = np.arange(len(groups))
    width = 0.8 / max(1, len(structures))
    fig, ax = plt.subplots(figsize=(max(6.5, 1.2 * len(groups) + 3), 3.9), layout="constrained")
    colours = model_colours(structures)
    for k, s in enumerate(structures):
        vals = [fits[s].get(d, np.nan) for d in datasets]
        mean, se = mean_and_se(vals)
        pos = x + (k - (len(structures) - 1) / 2) * width
        ax.bar(pos[:-1], vals, width, label=s, color=colours[s])
        ax.bar(pos[-1], mean, width, yerr=se, capsize=3, color=colours[s], hatch="//", edgecolor="white")
    ax.axvline(len(datasets) - 0.5, color="grey", lw=0.8, ls=":")
    ax.set_xticks(x, groups, rotation=20, ha="right")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(metric)
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    _legend_outside(ax, len(structures))
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
            ax.plot(
                grid, c * (1 - grid / 100) ** n, color="#d62728", label=f"{c:.3g} (1 - phi/100)^{n:.2f}, R^2 {r2:.2f}"
            )
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
