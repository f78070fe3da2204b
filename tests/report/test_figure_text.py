"""Figures a reviewer accepts: every report page rendered in headless Chromium, every figure's text
(titles, axis labels, legends) read from the matplotlib objects it was drawn from and checked by
tests/report/figure_text.py: a quantity and a unit on every axis, a fit on every curve compared
with data, no nan, no more than 4 decimals. And the items a review flagged, one by one.

Recordings: the simulated contractor at 20 Hz (porosense simulate), a linear and a Wiener model
fitted at fixed orders; the figures are what is tested, not the models.
"""

from __future__ import annotations

import html
import json
import re

import numpy as np
import pytest

from porosense.cli import main

from ._browser import render
from .figure_text import page_problems, problems


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from porosense import ident
    from porosense.data import load_data

    d = tmp_path_factory.mktemp("figtext")
    args = ["simulate", "contractor", "-e", "step_20", "-e", "staircase", "--rate", "20", "--out", str(d)]
    assert main(args) == 0
    paths = sorted(d.glob("contractor_*.csv"))
    tables = [load_data(p) for p in paths]
    u = [t.columns["dR_0"][:, None] for t in tables]
    y = [t.columns["strain_0"] for t in tables]
    for kind, poles in (("linear", 1), ("wiener", 2)):
        m = ident.make_model(kind, n_poles=poles, n_zeros=0 if poles == 1 else 1)
        m.fit(u=u, y=y, ts=0.05, inputs=("dR_0",), output="strain_0", input_unit="%", output_unit="%")
        m.save(d / f"{kind}.json")
    return d, paths


def _dom_figures(dom):
    return [json.loads(html.unescape(m)) for m in re.findall(r'<figure data-labels="([^"]*)"', dom)]


def test_report_page_figures_pass_review(files, tmp_path, capsys):
    d, paths = files
    out = tmp_path / "rep"
    argv = ["report", "--data", *map(str, paths), "--model", str(d / "linear.json"), str(d / "wiener.json")]
    assert main([*argv, "--out", str(out)]) == 0
    capsys.readouterr()
    dom = render(out / "report.html", tmp_path / "profile")
    n_ok, n_all = (int(v) for v in re.search(r'data-figures-loaded="(\d+)/(\d+)"', dom).groups())
    assert n_ok == n_all >= 6
    found = page_problems(sorted((out / "figures").glob("*.png")))
    assert not found, "\n".join(found)
    figures = _dom_figures(dom)
    assert len(figures) == n_all and not [p for i, f in enumerate(figures) for p in problems(f, f"page figure {i}")]
    loops = [f for f in figures if "against" in f["axes"][0]["title"] and "hysteresis" not in f["axes"][0]["title"]]
    assert loops and all(f["axes"][0]["title"].endswith("strain_0 against dR_0") for f in loops)
    assert all(f["axes"][0]["xlabel"] == "dR_0 (%)" and f["axes"][0]["ylabel"] == "strain_0 (%)" for f in loops)
    nonlinear = [f for f in figures if f["axes"][0]["title"].startswith("wiener: strain_0 g")]
    assert nonlinear and "a.u." not in json.dumps(nonlinear)
    assert nonlinear[0]["axes"][0]["ylabel"] == "steady-state strain_0 (%)"
    assert nonlinear[0]["axes"][0]["xlabel"] == "steady-state dR_0 (%)"
    # Table S2: a one-pole model has one pole per block, not a padded one at 0.0000.
    s2 = re.search(r"<caption>Table S2.*?</table>", dom, re.S).group(0)
    linear_row = re.search(r"<tr><td[^>]*>linear</td>.*?</tr>", s2, re.S).group(0)
    assert "0.0000" not in linear_row and len(re.findall(r"0\.\d{4}", linear_row)) == 1, linear_row
    recs = re.search(r"<caption>Recordings.*?</table>", dom, re.S).group(0)
    assert ">82<" in recs and ">0<" in recs and "82.0000" not in recs and "?" not in recs
    assert not re.search(r"\bnan\b", dom)


def test_loading_is_the_vacuum_rising_not_dr_rising():
    """A vacuum actuator's resistance falls as it is loaded: the loading branch must hold the
    samples where the applied vacuum rises, whichever way dR goes."""
    from porosense.report.analysis import hysteresis_branches

    t = np.linspace(0, 2 * np.pi, 400)
    vacuum = 30 * (1 - np.cos(t))  # kPa of vacuum: up, then down
    dr = -vacuum - 5 * np.sin(t)  # dR falls as the vacuum rises, with a loop
    strain = 0.3 * vacuum
    branches = hysteresis_branches(dr, strain, load=vacuum)
    loading, unloading = branches["loading"], branches["unloading"]
    # Along loading dR is lower for the same strain than along unloading (the loop's lower branch).
    x_mid = -30.0
    assert np.interp(x_mid, loading["x"], loading["y"]) != pytest.approx(
        np.interp(x_mid, unloading["x"], unloading["y"])
    )
    rising_dr = hysteresis_branches(dr, strain)  # the old rule: dR rising called loading
    assert rising_dr["loading"]["samples"] == branches["unloading"]["samples"]


def test_diagnose_figures_pass_review_and_mark_only_significant_lines(files, tmp_path, capsys):
    d, paths = files
    out = tmp_path / "diag"
    argv = ["diagnose", "--data", str(paths[0]), "--input", "dR_0", "--output", "strain_0"]
    assert (
        main([*argv, "--model", str(d / "linear.json"), "--out", str(out), "--json-out", str(tmp_path / "d.json")]) == 0
    )
    capsys.readouterr()
    figures = sorted(out.glob("*.png"))
    found = page_problems(figures)
    assert not found, "\n".join(found)
    from porosense.report.figures import read_labels

    spectrum = read_labels(out / "spectrum.png")["axes"][0]
    doc = json.loads((tmp_path / "d.json").read_text())
    periodic = [f for f in doc["findings"] if f["cause"] == "periodic_disturbance"]
    if not periodic or not periodic[0].get("significant", False):
        assert "no significant line" in spectrum["title"] and not spectrum["legend"]
    fits = read_labels(out / "fits.png")["axes"][0]["legend"]
    assert any(e.startswith("nominal model (fit ") for e in fits), fits
    dom = render(out / "diagnosis.html", tmp_path / "profile")
    n_ok, n_all = (int(v) for v in re.search(r'data-figures-loaded="(\d+)/(\d+)"', dom).groups())
    assert n_ok == n_all == 4
    assert not [p for i, f in enumerate(_dom_figures(dom)) for p in problems(f, f"diagnosis figure {i}")]
    assert "fit, nominal model" in dom and not re.search(r"\bnan\b", dom)


def test_closed_loop_figure_and_text_carry_units_and_never_nan(tmp_path):
    from porosense.control.runner import plot_run
    from porosense.data import Recording
    from porosense.report.figures import read_labels
    from porosense.workflows.demo_report import _step_text

    t = np.arange(200) * 0.02
    target = np.where(t > 0.5, 15.0, 0.0)
    true = np.convolve(target, np.ones(10) / 10, mode="same")
    rec = Recording(
        t,
        {"target_0": target, "est_strain_0": true + 0.1, "strain_0": true, "cmd_kpa_0": -2 * true},
        units={"strain_0": "%"},
    )
    plot_run(rec, tmp_path / "run.png", output="strain_0")
    labels = read_labels(tmp_path / "run.png")
    assert not problems(labels), problems(labels)
    assert labels["axes"][0]["ylabel"] == "strain_0 (%)"
    assert any("fit" in e for e in labels["axes"][0]["legend"])
    text = _step_text({"target": 15.0, "settling_s": float("nan"), "overshoot_pct": 2.0, "steady_error": 0.1})
    assert "nan" not in text and "did not settle" in text
