"""The independent hidden-effect generator: reproducible, finite, and every effect stands out of the noise."""

import numpy as np
import pytest

from porosense.bench import hidden_effects as h


def test_same_seed_same_data_other_seed_other_data():
    a, b, c = h.draw_trial("drift", 3), h.draw_trial("drift", 3), h.draw_trial("drift", 4)
    assert np.array_equal(a.estimation["y"], b.estimation["y"])
    assert not np.array_equal(a.estimation["y"][:100], c.estimation["y"][:100])


@pytest.mark.parametrize("kind", h.CAUSES + h.FALSE_ALARM_KINDS)
def test_records_are_finite_and_carry_every_column(kind):
    t = h.draw_trial(kind, 11)
    for rec in (t.estimation, t.validation):
        assert set(rec) == {"u", "y", "u_aux", "load"}
        n = len(rec["y"])
        assert n >= 1200
        assert all(len(v) == n and np.all(np.isfinite(v)) for v in rec.values())
    assert 1 <= t.nominal_order <= t.true_order <= 3


@pytest.mark.parametrize("kind", [k for k in h.CAUSES if k != "unmodelled_dynamics"])
def test_hidden_effect_exceeds_the_noise_in_most_draws(kind):
    # A trial whose effect is buried in the noise scores nothing; the ranges must keep the
    # effect's RMS above the noise RMS in at least 8 of 10 draws.
    ratios = [h.draw_trial(kind, s).effect_to_noise for s in range(10)]
    assert sum(r > 1.0 for r in ratios) >= 8, ratios


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown trial kind"):
        h.draw_trial("gremlins", 1)
