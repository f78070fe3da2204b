"""The demo's report folder: the figures this field expects and a summary page."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.report.figures import (
    fit_power_law,
    plot_fit_bars,
    plot_hysteresis,
    plot_power_law,
    plot_reconstruction,
)
from porosense.report.page import DataTable, Section, write_report

PAPER_POROSITIES = (68.0, 76.0, 82.0, 86.0)


def search_tables(searches, names, outputs, kept=None) -> list:
    """The demo's fit tables, one per output.

    Parameters
    ----------
    searches : list of SearchResult
        One order search per output.
    names : list of str
        The recordings, in the searches' order.
    outputs : list of str
        One name per output.
    kept : list of str, optional
        The structure kept per output (default each search's best).

    Returns
    -------
    list of DataTable
        Fit % and RMS % of each structure's best model per recording, and the mean.
    """
    tables = []
    for k, (o, res) in enumerate(zip(outputs, searches)):
        best = kept[k] if kept else res.best.structure
        rows = []
        for s, c in sorted(
            res.best_per_structure().items(), key=lambda kv: ("linear", "hammerstein", "wiener", "wh").index(kv[0])
        ):
            cells = [
                f"{f:.1f} / {r:.1f}"
                for f, r in zip(c.fit_estimation + c.fit_validation, c.rms_estimation + c.rms_validation)
            ]
            rows.append(
                [("* " if s == best else "") + s, c.n_poles, c.n_zeros, *cells, f"{c.mean_fit:.1f} / {c.mean_rms:.1f}"]
            )
        rule = "the paper's structure and orders" if kept else "selected by mean fit"
        tables.append(
            DataTable(
                f"{o}: fit % / RMS % per recording (* {rule})", ["structure", "poles", "zeros", *names, "mean"], rows
            )
        )
    return tables


def _number(value: float, fmt: str, missing: str) -> str:
    return format(value, fmt) if value is not None and np.isfinite(value) else missing


def _step_text(s: dict) -> str:
    """One closed-loop step in words; a step that did not settle within its hold says so (never nan)."""
    settle = _number(s.get("settling_s"), ".2f", "")
    return (
        f"target {s['target']:.3g}: "
        + (f"settled in {settle} s" if settle else "did not settle within the hold (2 % band)")
        + f", overshoot {_number(s.get('overshoot_pct'), '.1f', 'n/a')} %, steady-state error "
        + _number(s.get("steady_error"), "+.3f", "n/a")
    )


def write_demo_report(result, searches, live, structure, out: Path, inputs, outputs, labels, control_run=None) -> Path:
    """Write figures and summary pages for one actuator's demo; returns the folder.

    ``inputs``/``outputs`` are the column names, ``labels`` the outputs' axis labels (with units);
    ``control_run`` the closed-loop segment's recording (target, estimate, truth), if any.
    """
    recs = result.recordings
    figs = Path(out) / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    sections = []

    # Reconstruction on the first validation recording, every structure's best model.
    val_name = [n for n in recs if n.startswith(("step_20", "sequential_20"))][0]
    vrec = recs[val_name]
    u = np.column_stack([vrec[c] / 100.0 for c in inputs])
    recon = []
    for j, (o, res) in enumerate(zip(outputs, searches)):
        est = {s: c.model.predict(u=u) for s, c in res.best_per_structure().items()}
        path = figs / f"reconstruction_{o}.png"
        plot_reconstruction(
            vrec.t,
            vrec[o],
            est,
            ylabel=labels[j],
            title=f"{result.actuator}: {o} on {val_name} (validation)",
            path=path,
        )
        recon.append(path)
    sections.append(
        Section(
            "Measured versus estimated",
            "Each structure's best model of the order search, simulated from rest on a validation recording.",
            figures=recon,
            tables=search_tables(
                searches,
                list(recs),
                outputs,
                [v["structure"] for v in result.selected.values()]
                if any(v.get("rule") == "paper orders" for v in result.selected.values())
                else None,
            ),
        )
    )

    # Hysteresis loops: a step and the staircase.
    loops = []
    for name in [n for n in recs if n.startswith(("step_20", "staircase", "sequential_20"))][:2]:
        r = recs[name]
        path = figs / f"hysteresis_{name}.png"
        plot_hysteresis(
            r[inputs[0]],
            r[outputs[0]],
            ylabel=labels[0],
            title=f"{name}: {outputs[0]} against {inputs[0]}",
            colour=r.t,
            colour_label="time (s)",
            path=path,
        )
        loops.append(path)
    sections.append(
        Section(
            "Hysteresis",
            "The loop area is the rate-dependent hysteresis and relaxation that "
            "the Wiener-Hammerstein model captures and the linear model cannot.",
            figures=loops,
        )
    )

    # Fit bar chart per structure and recording.
    bars = []
    for o, res in zip(outputs, searches):
        per = res.best_per_structure()
        names = list(recs)
        fits = {
            s: dict(zip(names, c.fit_estimation + c.fit_validation))
            for s, c in sorted(per.items(), key=lambda kv: ("linear", "hammerstein", "wiener", "wh").index(kv[0]))
        }
        path = figs / f"fit_bars_{o}.png"
        plot_fit_bars(
            fits, title=f"{result.actuator}: fit of {o} per structure and recording", path=path, xlabel="recording"
        )
        bars.append(path)
    sections.append(Section("Fit per structure", "", figures=bars))

    # On-device estimate, live.
    live_figs = []
    for j, o in enumerate(outputs):
        path = figs / f"on_device_{o}.png"
        plot_reconstruction(
            live.t,
            live[o],
            {"wh": live[f"est_{o}"]},
            ylabel=labels[j],
            title=f"on-device estimate of {o}, streamed live",
            path=path,
        )
        live_figs.append(path)
    text = "\n\n".join(
        f"{o}: on-device fit {a:.2f} %, host float model {b:.2f} % ({a - b:+.2f} points)."
        for o, a, b in zip(outputs, result.on_device_fit, result.float_fit)
    )
    verify = result.verify
    text += (
        f"\n\nModel blob {result.quant['bytes']} bytes; replay of {verify['samples']} samples through the "
        f"board: {verify['mismatches']} mismatches with the bit-exact reference."
    )
    sections.append(Section("On the device", text, figures=live_figs))

    if control_run is not None and result.control:
        from porosense.control.runner import plot_run

        path = figs / "closed_loop.png"
        plot_run(
            control_run,
            path,
            output=outputs[0],
            title=f"closed loop on the board: target, on-device estimate and true {outputs[0]}",
        )
        c = result.control
        steps = "; ".join(_step_text(s) for s in c["steps"])
        text = (
            f"The board's PI controller holds {outputs[0]} on its own estimate, with gains tuned from the "
            f"recordings above (lambda rule on an FOPDT: K {c['plant']['K']:.3g} per kPa, T "
            f"{c['plant']['T']:.3f} s; kp {c['gains']['kp_kpa']:.3g} kPa per unit, ki "
            f"{c['gains']['ki_kpa_per_s']:.3g} kPa per unit s). Errors against the true {outputs[0]}: {steps}."
        )
        sections.append(Section("Closed loop", text, figures=[path]))

    if result.actuator == "contractor":
        from porosense.sim import steady_state

        ss = [steady_state("contractor", porosity=p, load_g=0.0, vacuum_kpa=-60.0) for p in PAPER_POROSITIES]
        strain = [s["strain_pct"] for s in ss]
        dr = [s["dR_pct"] for s in ss]
        fits = {
            "strain at -60 kPa (%)": fit_power_law(PAPER_POROSITIES, strain),
            "dR at -60 kPa (%)": fit_power_law(PAPER_POROSITIES, dr),
        }
        path = figs / "porosity_power_law.png"
        plot_power_law(
            PAPER_POROSITIES,
            {"strain at -60 kPa (%)": strain, "dR at -60 kPa (%)": dr},
            fits,
            title="contractor: p = C (1 - phi/100)^n",
            path=path,
        )
        sections.append(
            Section(
                "Porosity",
                "Stroke and sensitivity of contractors printed at 68, 76, 82 and 86 % porosity (simulated).",
                figures=[path],
            )
        )

    sel = "; ".join(
        f"{o}: {v['structure']} with {v['poles']} poles and {v['zeros']} zeros, mean fit {v['mean_fit']:.1f} %"
        for o, v in result.selected.items()
    )
    paper = any(v.get("rule") == "paper orders" for v in result.selected.values())
    how = (
        "Fitted at the paper's orders (WH, 2 poles and 1 zero, 10 breakpoints; the other structures at the "
        "same orders for comparison)"
        if paper
        else "Selected by mean fit over estimation and validation recordings"
    )
    store = result.verify.get("store")
    where = (
        f" Stored in the board's {store} store, verified by replay ({result.verify.get('samples')} samples, bit-exact)."
        if store
        else ""
    )
    intro = f"Actuator: {result.actuator}; board: {result.board}. {how}: {sel}.{where}"
    write_report(out, f"porosense demo: {result.actuator}", sections, intro=intro)
    return Path(out)
