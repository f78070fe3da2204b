"""Conformance: the on-device estimator is bit-exact with the Python reference."""

from __future__ import annotations

import numpy as np
from models import reference_run

from porosense.quant import FixedPointEstimator, ModelBlob


def inputs(n: int, seed: int) -> np.ndarray:
    """A bounded random walk in dR (0.01 %), three channels."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0, 300, size=(n, 3)), axis=0)
    return np.clip(x, -9000, 4000).astype(np.int16)


def test_replay_matches_the_reference_bit_for_bit(dev, blob3):
    dev.write_model(blob3)
    x = inputs(200, seed=3)
    got = dev.replay(x)
    want = reference_run(blob3, x)
    assert got.shape == (200, 3)
    assert np.array_equal(got, want), np.argwhere(got != want)[:5]


def test_replay_continues_the_state_without_reset(dev, blob):
    dev.write_model(blob)
    x = inputs(64, seed=4)
    first = dev.replay(x[:40])
    rest = dev.replay(x[40:], reset=False)
    assert np.array_equal(np.vstack([first, rest]), reference_run(blob, x))


def test_saturation_is_flagged(dev, blob):
    dev.write_model(blob)
    x = np.full((16, 3), 32767, dtype=np.int16)
    _, flags = dev.replay(x, return_flags=True)
    want_flags = _reference_flags(blob, x)
    assert int(flags[0]) == int(want_flags.any())


def test_streamed_estimates_match_the_reference(dev, blob):
    dev.write_model(blob)
    dev.start_stream(100)  # resets the estimator
    samples = list(dev.samples(150))
    dev.stop_stream()
    assert dev.stats.samples_lost == 0
    dr = np.array([s.dr_centi for s in samples], dtype=np.int16)
    est = np.array([s.estimate for s in samples], dtype=np.int16)
    assert np.array_equal(est, reference_run(blob, dr))
    assert np.any(est[:, 0] != 0)


def _reference_flags(blob, x):
    return FixedPointEstimator(ModelBlob.from_bytes(blob)).run(x)[1] & 1
