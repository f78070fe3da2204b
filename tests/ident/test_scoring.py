"""The one fit every command prints (porosense.ident.simulation_fit), against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from porosense.errors import InputError, ModelError
from porosense.ident import format_percent, simulation_fit


class _Fixed:
    """A stand-in model whose simulation is a given array (the fit's arithmetic is what is tested)."""

    output = "y"

    def __init__(self, yhat):
        self.yhat = np.asarray(yhat, float)

    def predict(self, *, u, expected=False):
        return self.yhat


def test_fit_and_rms_match_the_definitions_by_hand():
    # y = 1, 2, 3, 4 and yhat = 1, 2, 3, 5: ||e|| = 1, ||y - mean|| = sqrt(5), max|y| = 4.
    scored = simulation_fit(_Fixed([1, 2, 3, 5]), np.zeros(4), [1, 2, 3, 4])
    assert scored.fit["y"] == pytest.approx(100 * (1 - 1 / math.sqrt(5)), abs=1e-12)  # 55.28 %
    assert scored.rms["y"] == pytest.approx(100 * math.sqrt(0.25) / 4, abs=1e-12)  # 12.50 %
    assert scored.initial == "rest" and scored.samples == 4
    assert str(scored) == "y: fit 55.28 %, RMS 12.50 % of max |y|"


def test_a_constant_output_prints_n_a_never_nan():
    scored = simulation_fit(_Fixed([1, 1, 1]), np.zeros(3), [2, 2, 2])
    assert math.isnan(scored.fit["y"]) and "nan" not in str(scored).lower() and "n/a" in str(scored)
    assert format_percent(float("inf")) == "n/a" and format_percent(12.345) == "12.35 %"


def test_bad_lengths_and_divergence_are_refused():
    with pytest.raises(InputError, match="samples"):
        simulation_fit(_Fixed([1, 2]), np.zeros(3), [1, 2])
    with pytest.raises(ModelError, match="diverges"):
        simulation_fit(_Fixed([1, np.inf, 3]), np.zeros(3), [1, 2, 4])
