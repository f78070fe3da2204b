"""``porosense report``: the paper's figures and tables from the user's own recordings and models.

Given recordings (any file ``load_data`` reads) and saved models, writes into a folder:

- reconstruction per recording and output, every model's NRMSE fit in the legend;
- bar graphs of fit and of RMS (% of max |y|) per recording, with mean ± standard error;
- Table 1: mean ± standard error of fit and RMS per model and output;
- Table S2: poles and zeros of every linear block of every model;
- hysteresis loops (input against output) coloured by pressure (kPa) or time (s), with
  polynomial fits per direction (loading, unloading) and their R^2;
- each identified static nonlinearity with its breakpoints fitted to a exp(b x) (R^2);
- the porosity analysis from measured hold averages per pressure, load and porosity (when the
  recordings state their porosity): power laws C (1 - phi/100)^n with R^2 (Table S1).
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

import numpy as np

from porosense.report.analysis import (
    compare,
    fit_exponential,
    format_roots,
    hold_averages,
    hysteresis_branches,
    model_outputs,
    poles_zeros,
)
from porosense.report.figures import (
    _finish,
    _plt,
    fit_power_law,
    plot_fit_bars,
    plot_hysteresis,
    plot_reconstruction,
)
from porosense.report.page import DataTable, Section, write_report

MAX_RECONSTRUCTIONS = 6
MAX_LOOPS = 4
MIN_HOLD_S = 2.0  # shortest pressure hold averaged in the porosity analysis (s)


def _label(name: str, units: dict) -> str:
    """'strain_0 (%)' from the data's or the models' units, the column conventions, or 'unit not stated'."""
    from porosense.data.units import axis_label

    return axis_label(name, units)


def _model_units(models: dict) -> dict:
    """Units the models carry: outputs' units, and dR inputs in % or dR/100."""
    out = {}
    for m in models.values():
        for sub in getattr(m, "models", [m]):
            if getattr(sub, "output_unit", None):
                out.setdefault(sub.output, sub.output_unit)
            for name, unit in zip(sub.inputs, getattr(sub, "input_units", ()) or ()):
                if unit:
                    out.setdefault(name, unit)
    return out


def _stated(value, unit: str = "") -> str:
    """A number as people write it (82 %, 0 g), or 'not stated'."""
    if isinstance(value, (int, float)) and np.isfinite(value):
        return f"{value:g}{unit}"
    return "not stated"


def _pm(mean: float, se: float) -> str:
    return f"{mean:.1f} ± {se:.1f}" if np.isfinite(mean) and np.isfinite(se) else "n/a (constant output)"


def _static_views(sub, units: dict) -> list:
    """(block, x, y, x label, y label) of every static map of one output's chain, in physical units
    where the linear blocks around it allow: a map's output times the DC gains after it is its
    steady-state contribution to the output; g's input over H1's DC gain is the input it stands for."""
    chain = sub.output_chain()
    out_unit = _label(sub.output, units)
    views = []
    single = len(chain.branches) == 1
    for br in chain.branches:
        if br.f is None:
            continue
        name = sub.inputs[br.input]
        after = br.h1.dc_gain
        if chain.g is None:
            after *= chain.h2.dc_gain if chain.h2 is not None else 1.0
            y = np.asarray(br.f.y) * after + (chain.offset if single else 0.0)
            what = "steady-state " if single else f"steady-state contribution of {name} to "
            ylab = f"{what}{out_unit}"
        else:
            y, ylab = np.asarray(br.f.y), f"f({name}), into H1 (1: scaled by the input's spread)"
        views.append((f"f[{name}]", np.asarray(br.f.x), y, _label(name, units), ylab))
    if chain.g is not None:
        k1 = chain.branches[0].h1.dc_gain if single else 0.0
        x = np.asarray(chain.g.x)
        if single and chain.branches[0].f is None and abs(k1) > 1e-9:
            x = x / k1
            xlab = f"steady-state {_label(sub.inputs[chain.branches[0].input], units)}"
        else:
            xlab = "sum of the H1 outputs (1: scaled by the inputs' spread)"
        k2 = chain.h2.dc_gain if chain.h2 is not None else 1.0
        views.append(("g", x, np.asarray(chain.g.y) * k2 + chain.offset, xlab, f"steady-state {out_unit}"))
    return views


def _short(path) -> str:
    return Path(str(path)).stem


def plot_nonlinearity(x, y, fit, *, xlabel: str, ylabel: str, title: str = "", path=None):
    """Breakpoints of a static map, the map itself, and the fitted a exp(b x) curve."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.6, 4.0), layout="constrained")
    ax.plot(x, y, "o-", color="black", label="identified breakpoints")
    a, b, r2 = fit
    grid = np.linspace(min(x), max(x), 200)
    ax.plot(grid, a * np.exp(b * grid), color="#d62728", label=f"{a:.3g} exp({b:.3g} x), R² {r2:.3f}")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return _finish(fig, path)


def plot_porosity(groups: dict, fits: dict, *, ylabel: str, title: str = "", path=None):
    """Hold averages against porosity (%) per (pressure, load) group with their power-law fits."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, max(1, len(groups))))
    for c, (key, pts) in zip(colours, sorted(groups.items())):
        phi = np.array(sorted(pts))
        v = np.array([pts[p] for p in phi])
        label = f"{key[0]:g} kPa, {key[1]:g} g"
        ax.plot(phi, v, "o", color=c)
        if key in fits:
            C, n, r2 = fits[key]
            grid = np.linspace(phi.min() - 2, phi.max() + 2, 100)
            ax.plot(grid, C * (1 - grid / 100) ** n, color=c, label=f"{label}: n {n:.2f}, R² {r2:.2f}")
        else:
            ax.plot([], [], "o", color=c, label=label)
    ax.set_xlabel("porosity (%)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return _finish(fig, path)


def write_user_report(
    tables,
    models: dict,
    out,
    *,
    units: dict | None = None,
    pressure: str | None = None,
    title: str = "porosense report",
) -> Path:
    """Write the report for ``tables`` (porosense.data Tables) and ``models`` (name -> model) into
    ``out``; returns the HTML page's path. ``units`` maps columns to units (added to those the
    recordings' sidecars state); ``pressure`` names the commanded-pressure column in kPa (default:
    p_cmd_0 when present)."""
    out = Path(out)
    figs = out / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    units = {**_model_units(models), **{k: v for t in tables for k, v in t.units.items()}, **(units or {})}
    pressure = pressure or ("p_cmd_0" if all("p_cmd_0" in t.columns for t in tables) else None)
    scores = {name: compare(m, tables, name) for name, m in models.items()}
    outputs = list(dict.fromkeys(o for m in models.values() for o in model_outputs(m)))
    first = next(iter(models.values()))
    inputs = list(first.inputs)
    sections = []

    # Data.
    rows = [
        [
            _short(t.path),
            len(t),
            f"{t.ts * 1000:.4g}" if t.ts else "not stated",
            t.dialect,
            _stated(t.meta.get("porosity")),
            _stated(t.meta.get("load_g")),
        ]
        for t in tables
    ]
    sections.append(
        Section(
            "Recordings",
            "Each recording is simulated from rest by every model.",
            tables=[
                DataTable(
                    "Recordings", ["recording", "samples", "Ts (ms)", "read as", "porosity (%)", "load (g)"], rows, 4
                )
            ],
        )
    )

    # Reconstruction with fits in the legend.
    recon = []
    for t in tables[:MAX_RECONSTRUCTIONS]:
        key = str(t.path)
        time = t.time if getattr(t, "time", None) is not None else np.arange(len(t)) * (t.ts or first.ts)
        for o in outputs:
            est = {name: r.predictions[key][:, r.outputs.index(o)] for name, r in scores.items() if o in r.outputs}
            path = figs / f"reconstruction_{_short(key)}_{o}.png"
            plot_reconstruction(
                time, t.columns[o], est, ylabel=_label(o, units), title=f"{o} on {_short(key)}", path=path
            )
            recon.append(path)
    sections.append(
        Section(
            "Measured versus estimated",
            "Every model simulated from rest on each recording; the legend gives each model's NRMSE fit.",
            figures=recon,
        )
    )

    # Fit and RMS bars; Table 1.
    bars, t1_rows = [], []
    for o in outputs:
        fits = {n: {_short(f): r.fit[f][o] for f in r.files} for n, r in scores.items() if o in r.outputs}
        rmss = {n: {_short(f): r.rms[f][o] for f in r.files} for n, r in scores.items() if o in r.outputs}
        for metric, values, tag in (("fit (%)", fits, "fit"), ("RMS (% of max |y|)", rmss, "rms")):
            path = figs / f"{tag}_bars_{o}.png"
            plot_fit_bars(
                values,
                metric=metric,
                xlabel="recording",
                title=f"{o}: {tag} per recording, mean ± standard error",
                path=path,
            )
            bars.append(path)
        for n, r in scores.items():
            if o in r.outputs:
                s = r.summary(o)
                t1_rows.append(
                    [
                        n,
                        o,
                        _pm(s["fit_mean"], s["fit_se"]),
                        _pm(s["rms_mean"], s["rms_se"]),
                        s["files"],
                    ]
                )
    sections.append(
        Section(
            "Fit and RMS per recording",
            "RMS is scaled to the largest |output| of each "
            "recording, as the paper reports it. Standard error: sample standard deviation / √n.",
            figures=bars,
            tables=[
                DataTable(
                    "Table 1: mean ± standard error over the recordings",
                    ["model", "output", "fit (%)", "RMS (%)", "recordings"],
                    t1_rows,
                )
            ],
        )
    )

    # Table S2: poles and zeros.
    pz_rows = []
    for n, m in models.items():
        for row in poles_zeros(m):
            pz_rows.append(
                [
                    n,
                    row["output"],
                    row["block"],
                    format_roots(row["poles"]),
                    format_roots(row["zeros"]),
                    ", ".join(f"{v:.3g}" for v in row["time_constants_s"]) or "none",
                ]
            )
    sections.append(
        Section(
            "Poles and zeros",
            f"Discrete-time (z, Ts = {first.ts:g} s) poles and zeros of "
            "every linear block; time constants of the real poles.",
            tables=[
                DataTable(
                    "Table S2: poles and zeros of each model",
                    ["model", "output", "block", "poles (z)", "zeros (z)", "time constants (s)"],
                    pz_rows,
                )
            ],
        )
    )

    # Hysteresis loops with fitted branches.
    loops, loop_rows = [], []
    x_name, y_name = inputs[0], outputs[0]
    for t in tables[:MAX_LOOPS]:
        x, y = t.columns[x_name], t.columns[y_name]
        # Loading is the vacuum rising (the gauge command falling), else the output rising: the
        # resistance of a vacuum actuator falls as it is loaded.
        load = -np.asarray(t.columns[pressure]) if pressure and pressure in t.columns else y
        branches = hysteresis_branches(x, y, load=load)
        if pressure and pressure in t.columns:
            colour, clabel = t.columns[pressure], f"{pressure} (kPa)"
        else:
            colour = t.time if getattr(t, "time", None) is not None else np.arange(len(t)) * (t.ts or first.ts)
            clabel = "time (s)"
        path = figs / f"hysteresis_{_short(t.path)}.png"
        plot_hysteresis(
            x,
            y,
            ylabel=_label(y_name, units),
            title=f"{_short(t.path)}: {y_name} against {x_name}",
            colour=colour,
            colour_label=clabel,
            path=path,
            xlabel=_label(x_name, units),
            fits={d: (b["x"], b["y"]) for d, b in branches.items()},
        )
        loops.append(path)
        for d, b in branches.items():
            loop_rows.append([_short(t.path), d, b["samples"], b["r2"]])
    sections.append(
        Section(
            "Hysteresis",
            "Loading (vacuum rising: the pressure command falling; without a pressure column, the output "
            "rising) and unloading branches, each fitted with a cubic polynomial. The resistance of a vacuum "
            "actuator falls as it is loaded.",
            figures=loops,
            tables=[DataTable("Fits per direction", ["recording", "direction", "samples", "R²"], loop_rows, 3)],
        )
    )

    # Static nonlinearities against a exp(b x).
    nl_figs, nl_rows = [], []
    for n, m in models.items():
        for sub in getattr(m, "models", [m]):
            for block, x, y, xl, yl in _static_views(sub, units):
                fit = fit_exponential(x, y)
                path = figs / (re.sub(r"[^\w.-]+", "_", f"nonlinearity_{n}_{sub.output}_{block}") + ".png")
                plot_nonlinearity(x, y, fit, xlabel=xl, ylabel=yl, title=f"{n}: {sub.output} {block}", path=path)
                nl_figs.append(path)
                nl_rows.append([n, sub.output, block, len(x), fit[0], fit[1], fit[2]])
    if nl_figs:
        sections.append(
            Section(
                "Identified nonlinearities",
                "Each static map's breakpoints fitted to a exp(b x), drawn in the units of the data: a map's "
                "output times the DC gains of the linear blocks after it (its steady-state effect on the "
                "output), g's input over H1's DC gain (the input it stands for).",
                figures=nl_figs,
                tables=[
                    DataTable(
                        "Breakpoints fitted to a exp(b x)",
                        ["model", "output", "block", "breakpoints", "a", "b", "R²"],
                        nl_rows,
                        4,
                    )
                ],
            )
        )

    section = _porosity_section(tables, outputs, inputs, pressure, units, figs)
    if section is not None:
        sections.append(section)
    intro = (
        f"{len(tables)} recordings, {len(models)} model(s): {', '.join(models)}. Outputs: {', '.join(outputs)}; "
        f"inputs: {', '.join(inputs)}."
    )
    _, html_path = write_report(out, title, sections, intro=intro, name="report")
    return html_path


def _porosity_section(tables, outputs, inputs, pressure, units, figs):
    """Power laws over porosity from hold averages, grouped by pressure and load; None without porosities."""
    if not pressure or not all(isinstance(t.meta.get("porosity"), (int, float)) for t in tables):
        return None
    quantities = list(dict.fromkeys([outputs[0], inputs[0]]))
    per = {q: defaultdict(lambda: defaultdict(list)) for q in quantities}
    for t in tables:
        load = float(t.meta.get("load_g", 0.0) or 0.0)
        # Holds last seconds; a ramp's one-sample levels are not holds.
        min_samples = max(5, int(round(MIN_HOLD_S / 2 / (t.ts or 1.0))))
        for hold in hold_averages(t.columns[pressure], {q: t.columns[q] for q in quantities}, min_samples=min_samples):
            for q in quantities:
                per[q][(hold["pressure_kpa"], load)][float(t.meta["porosity"])].append(hold[q])
    figures, rows = [], []
    for q in quantities:
        groups = {k: {phi: float(np.mean(v)) for phi, v in d.items()} for k, d in per[q].items()}
        fits = {}
        for key, pts in groups.items():
            if len(pts) >= 3:
                phi = sorted(pts)
                fits[key] = fit_power_law(phi, [pts[p] for p in phi])
                rows.append([q, key[0], key[1], len(phi), *fits[key]])
        path = figs / f"porosity_{q}.png"
        plot_porosity(
            groups,
            fits,
            ylabel=f"hold average of {_label(q, units)}",
            title=f"{q} against porosity: C (1 - phi/100)^n",
            path=path,
        )
        figures.append(path)
    if not rows:
        return None
    return Section(
        "Porosity",
        "Hold averages (second half of every hold) per pressure, load and porosity, fitted "
        "with p = C (1 - phi/100)^n over porosity.",
        figures=figures,
        tables=[
            DataTable(
                "Table S1: power-law fits over porosity",
                ["quantity", "pressure (kPa)", "load (g)", "porosities", "C", "n", "R²"],
                rows,
                3,
            )
        ],
    )
