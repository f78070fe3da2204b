"""The AVR build of the estimator (inline assembly and the assembly cascade) against the Python
reference, bit for bit, in simavr: the random designed and fuzzed models of vectors.py plus
fuzzed models pinned to the rounding edges (feedback shifts 16 and 47, numerator shifts 0, 1
and 31), whose paths random draws reach only rarely."""

from dataclasses import replace

import numpy as np
import pytest
import vectors

from porosense.firmware import avr_cycles
from porosense.protocol.model_blob import numerator_limit
from porosense.quant import FixedPointEstimator

pytestmark = pytest.mark.skipif(avr_cycles.available() is not None, reason=f"missing {avr_cycles.available()}")

N_SAMPLES = 300


def _pinned(section, rng, n, sb):
    """The section with both feedback shifts n and numerator shift sb (b scaled to the limit);
    its feedback residues redrawn until it is stable (the board refuses unstable sections),
    else the direct form with both poles at 0."""
    b = np.asarray(section.b, dtype=np.int64)
    lim = numerator_limit(section.wide, sb)
    total = int(np.sum(np.abs(b))) or 1
    b = np.trunc(b * min(1.0, lim / total)).astype(np.int64)
    s = replace(section, n=(n, n), sb=sb, b=tuple(int(v) for v in b))
    for _ in range(100):
        if s.stable():
            return s
        s = replace(s, k=tuple(int(v) for v in rng.integers(-32768, 32768, 2)))
    return replace(s, delta=False, m=(0, 0), k=(0, 0))


def edge_cases(seed: int, count: int):
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(count):
        blob = vectors.fuzz_blob(rng)
        n, sb = (16, 47)[i % 2], (0, 1, 31)[i % 3]
        outs = tuple(
            replace(
                o,
                h2=tuple(_pinned(s, rng, n, sb) for s in o.h2),
                branches=tuple(
                    replace(br, sections=tuple(_pinned(s, rng, n, sb) for s in br.sections)) for br in o.branches
                ),
            )
            for o in blob.outputs
        )
        blob = replace(blob, outputs=outs)
        u = rng.integers(-32768, 32768, (N_SAMPLES, 3))
        est, flags = FixedPointEstimator(blob).run(u)
        cases.append((blob.to_bytes(), u, est, flags))
    return cases


def test_avr_estimator_matches_reference_on_random_and_edge_models():
    cases = vectors.make_cases(2024, 24, N_SAMPLES) + edge_cases(77, 12)
    saturating = sum(int(np.any(flags)) for _, _, _, flags in cases)
    assert saturating >= 6  # the clamp paths are exercised too
    exact = avr_cycles.check_vectors(cases)
    assert all(exact), f"cases differing from the reference: {[i for i, ok in enumerate(exact) if not ok]}"
