"""The paper's metrics: fit % (NRMSE, simulation) and RMS % of the peak."""

import numpy as np

from porosense.ident import fit_percent, rms_percent


def test_fit_and_rms_follow_the_paper_formulas():
    rng = np.random.default_rng(2)
    y = 10 + 5 * np.sin(np.linspace(0, 20, 500))
    yhat = y + rng.normal(0, 0.5, y.size)
    fit = 100 * (1 - np.linalg.norm(y - yhat) / np.linalg.norm(y - y.mean()))
    rms = 100 / y.max() * np.sqrt(np.mean((y - yhat) ** 2))
    assert abs(fit_percent(y, yhat) - fit) < 1e-9
    assert abs(rms_percent(y, yhat) - rms) < 1e-9
    assert fit_percent(y, y) == 100.0


def test_rms_percent_of_a_negative_output_uses_its_peak_magnitude():
    y = -np.abs(np.sin(np.linspace(0, 6, 300))) * 8.0  # a tilt that only goes negative
    yhat = y + 0.08
    assert abs(rms_percent(y, yhat) - 0.08 / np.abs(y).max() * 100) < 1e-9
    assert 0.99 < rms_percent(y, yhat) < 1.01  # 0.08 of a peak of about 8


def test_relative_standard_error_matches_the_spread_of_error_norms():
    """The tie rules' standard error, 1 / sqrt(2 n), against the measured spread of ||e|| over
    4000 draws of n Gaussian residuals (its own estimate has a relative error of about
    1 / sqrt(2 x 4000) = 1.1 %; bound 5 %)."""
    from porosense.ident.metrics import relative_standard_error

    rng = np.random.default_rng(3)
    for n in (50, 400, 3000):
        norms = np.linalg.norm(rng.standard_normal((4000, n)), axis=1)
        measured = np.std(norms) / np.mean(norms)
        assert abs(measured / relative_standard_error(n) - 1.0) < 0.05, (n, measured)
