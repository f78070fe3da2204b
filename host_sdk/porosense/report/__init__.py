"""Figures (matplotlib) and report pages (Markdown + self-contained HTML)."""

from porosense.report.figures import (
    fit_power_law,
    plot_fit_bars,
    plot_hysteresis,
    plot_power_law,
    plot_reconstruction,
)
from porosense.report.page import Section, write_report

__all__ = [
    "fit_power_law",
    "plot_fit_bars",
    "plot_hysteresis",
    "plot_power_law",
    "plot_reconstruction",
    "Section",
    "write_report",
]
