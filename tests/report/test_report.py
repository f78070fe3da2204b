"""Report figures and pages."""

from __future__ import annotations

import base64
import re

import numpy as np

from porosense.report import (
    Section,
    fit_power_law,
    plot_fit_bars,
    plot_hysteresis,
    plot_power_law,
    plot_reconstruction,
    write_report,
)


def test_power_law_fit_recovers_parameters():
    rng = np.random.default_rng(3)
    c, n = rng.uniform(-150, -80), rng.uniform(0.3, 1.5)
    phi = np.array([68.0, 72.0, 76.0, 80.0, 82.0, 86.0])
    v = c * (1 - phi / 100) ** n * (1 + rng.normal(0, 0.01, phi.size))
    c_fit, n_fit, r2 = fit_power_law(phi, v)
    assert abs(n_fit - n) < 0.1 and abs(c_fit / c - 1) < 0.15 and r2 > 0.95


def test_report_page_embeds_every_figure(tmp_path):
    t = np.linspace(0, 10, 500)
    y = np.sin(t)
    figs = [
        plot_reconstruction(t, y, {"linear": 0.9 * y, "wh": y + 0.01}, path=tmp_path / "reconstruction.png"),
        plot_hysteresis(-80 * np.abs(np.sin(t)), 20 * np.abs(np.sin(t + 0.2)), path=tmp_path / "loop.png"),
        plot_fit_bars({"linear": {"a": 70, "b": 72}, "wh": {"a": 85, "b": 83}}, path=tmp_path / "bars.png"),
        plot_power_law(
            [68, 76, 82, 86],
            {"strain (%)": [10, 15, 20, 24]},
            {"strain (%)": (50, -0.9, 0.9)},
            path=tmp_path / "law.png",
        ),
    ]
    assert len(figs) == 4
    pngs = sorted(tmp_path.glob("*.png"))
    md, html = write_report(tmp_path, "Test report", [Section("Figures", "Two\n\nparagraphs", "a  b\n1  2", pngs)])
    page = html.read_text()
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) == 4
    for img in images:
        assert base64.b64decode(img)[:8] == b"\x89PNG\r\n\x1a\n"
    assert md.read_text().count("![") == 4
