"""``porosense report`` on recordings and models the demo did not make, checked in headless Chromium."""

from __future__ import annotations

import html
import json
import re

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import load_data

from ._browser import render


@pytest.fixture(scope="module")
def user_files(tmp_path_factory):
    """Contractor recordings at three porosities (20 Hz) and a linear and a WH model identified on
    the 76 % staircase and -60 kPa steps."""
    d = tmp_path_factory.mktemp("user")
    for phi in (68, 76, 86):
        assert (
            main(
                [
                    "simulate",
                    "contractor",
                    "-e",
                    "step_20",
                    "-e",
                    "step_60",
                    "--porosity",
                    str(phi),
                    "--rate",
                    "20",
                    "--seed",
                    str(phi),
                    "--out",
                    str(d),
                ]
            )
            == 0
        )
    assert main(["simulate", "contractor", "-e", "staircase", "--porosity", "76", "--rate", "20", "--out", str(d)]) == 0
    est = sorted(str(p) for p in d.glob("contractor_staircase_p76_*.csv")) + sorted(
        str(p) for p in d.glob("contractor_step_60_p76_*.csv")
    )
    assert len(est) == 2
    for kind in ("linear", "wh"):
        assert (
            main(
                [
                    "identify",
                    "--data",
                    *est,
                    "--input",
                    "dR_0",
                    "--output",
                    "strain_0",
                    "--structure",
                    kind,
                    "--poles",
                    "2",
                    "--zeros",
                    "1",
                    "--starts",
                    "1",
                    "--quiet",
                    "--out",
                    str(d / f"{kind}.json"),
                ]
            )
            == 0
        )
    return d


@pytest.mark.slow
def test_report_renders_every_figure_and_table(user_files, tmp_path, capsys):
    d = user_files
    data = sorted(str(p) for p in d.glob("contractor_*.csv"))
    out = tmp_path / "rep"
    assert (
        main(
            [
                "report",
                "--data",
                *data,
                "--model",
                str(d / "linear.json"),
                str(d / "wh.json"),
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    page = out / "report.html"
    assert doc["html"] == str(page)
    dom = render(page, tmp_path / "profile", screenshot=tmp_path / "page.png")
    n_ok, n_all = (int(v) for v in re.search(r'data-figures-loaded="(\d+)/(\d+)"', dom).groups())
    print(f"figures loaded: {n_ok}/{n_all}")
    assert n_ok == n_all >= 6 + 2 + 4 + 1 + 2  # reconstructions, fit/RMS bars, loops, g, porosity

    captions = re.findall(r"<caption>(.*?)</caption>", dom)
    print("tables:", captions)
    for wanted in ("Table 1", "Table S2", "Table S1", "Fits per direction", "a exp(b x)"):
        assert any(wanted in c for c in captions), wanted
    assert "<pre>" not in dom

    figures = [json.loads(html.unescape(m)) for m in re.findall(r'<figure data-labels="([^"]*)"', dom)]
    assert len(figures) == n_all
    unit = re.compile(r"\(.+\)")
    for fig in figures:
        for ax in fig["axes"]:
            if ax["xlabel"] and ax["xlabel"] != "recording":
                assert unit.search(ax["xlabel"]), ax
            assert unit.search(ax["ylabel"]), ax  # colour bars carry theirs as the y label
    recon = [f for f in figures if f["axes"][0]["title"].startswith("strain_0 on ")]
    assert len(recon) == 6
    for f in recon:
        fits = [float(m) for e in f["axes"][0]["legend"] for m in re.findall(r"fit (-?[\d.]+) %", e)]
        assert len(fits) == 2  # one per model, in the legend
    # Table 1's numbers are the models' mean fits: WH beats linear on these recordings on average.
    t1 = re.search(r"<caption>Table 1.*?</table>", dom).group(0)
    means = {
        m.group(1): float(m.group(2))
        for m in re.finditer(
            r'<td class="txt">([^<]+)</td><td class="txt">strain_0</td>'
            r'<td class="txt">(-?[\d.]+) ±',
            t1,
        )
    }
    print("Table 1 mean fits:", means)
    assert means["wh"] > means["linear"]
    # Table S1: the power law over porosity explains the hold averages of strain at -60 kPa.
    s1 = re.search(r"<caption>Table S1.*?</table>", dom).group(0)
    row = re.search(r"strain_0</td><td class=\"num\">-60.000</td>(.*?)</tr>", s1).group(1)
    r2 = float(re.findall(r">(-?[\d.]+)<", row)[-1])
    print("strain at -60 kPa: power-law R^2", r2)
    assert r2 > 0.78  # the paper's mean R^2 for strain over porosity

    import matplotlib.image

    img = matplotlib.image.imread(tmp_path / "page.png")
    not_white = float(np.mean(img[..., :3].min(axis=-1) < 0.9))
    print(f"screenshot {img.shape}, {not_white:.1%} non-white")
    assert not_white > 0.05


def test_compare_scores_per_file_with_mean_and_standard_error(user_files, tmp_path, capsys):
    d = user_files
    files = sorted(str(p) for p in d.glob("contractor_step_*_p76_*.csv"))
    assert (
        main(["compare", "--model", str(d / "wh.json"), "--data", *files, "--json", "--plot", str(tmp_path / "c.png")])
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    fits = [row["strain_0"]["fit"] for row in doc["per_file"]]
    s = doc["summary"]["strain_0"]
    assert s["fit_mean"] == pytest.approx(np.mean(fits))
    assert s["fit_se"] == pytest.approx(np.std(fits, ddof=1) / np.sqrt(len(fits)))
    # The same numbers as predict prints per file.
    table = load_data(files[0])
    assert main(["predict", "--model", str(d / "wh.json"), "--data", files[0], "--json"]) == 0
    pred = json.loads(capsys.readouterr().out)
    assert pred["scores"]["strain_0"]["fit"] == pytest.approx(fits[0], abs=1e-9)
    assert len(table) > 100 and (tmp_path / "c.png").stat().st_size > 10_000
