"""Bit-exactness vectors: random models and inputs run through the Python reference,
written as text for tests/core/test_estimator.cpp.

File format (whitespace separated): ``cases K`` then per case ``case LEN N MAXLEN``, LEN blob
bytes in hex, then N lines ``u0 u1 u2 e0 e1 e2 flags``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.protocol.model_blob import MAX_BLOB_LEN, BranchQ, ModelBlob, OutputQ, PwlQ, SectionQ, numerator_limit
from porosense.quant import FixedPointEstimator, quantize
from porosense.quant.design import compact_tables
from porosense.quant.random_models import random_structure, step_inputs

KINDS = ("linear", "hammerstein", "wiener", "wh")


def random_section(rng: np.random.Generator) -> SectionQ:
    """Any stable section the format allows (the board refuses unstable ones): exercises every
    path; drawn until SectionQ.stable() holds."""
    while True:
        s = _random_fields(rng)
        if s.stable():
            return s


def _random_fields(rng: np.random.Generator) -> SectionQ:
    wide = bool(rng.random() < 0.4)
    delta = bool(rng.random() < 0.4)
    sb = int(rng.integers(0, 32))
    raw = rng.integers(-(2**31), 2**31, 3) if wide else rng.integers(-32768, 32768, 3)
    raw = np.trunc(raw * min(1.0, numerator_limit(wide, sb) / np.sum(np.abs(raw)))).astype(np.int64)
    m = (0, 0) if delta else (int(rng.integers(-2, 3)), int(rng.integers(-1, 2)))
    return SectionQ(
        tuple(int(v) for v in raw),
        tuple(int(v) for v in rng.integers(-32768, 32768, 2)),
        sb,
        tuple(int(v) for v in rng.integers(16, 48, 2)),
        wide,
        delta,
        m,
    )


def random_table(rng: np.random.Generator) -> PwlQ:
    n = int(rng.integers(2, 17))
    x = np.sort(rng.choice(np.arange(-32768, 32768), n, replace=False))
    y = tuple(int(v) for v in rng.integers(-32768, 32768, n))
    if rng.random() < 0.5:  # compact: the slope of each segment from its breakpoints
        return PwlQ(tuple(int(v) for v in x), y, compact=True)
    return PwlQ(
        tuple(int(v) for v in x),
        y,
        tuple(int(v) for v in rng.integers(-32768, 32768, n - 1)),
        tuple(int(v) for v in rng.integers(0, 31, n - 1)),
    )


def fuzz_blob(rng: np.random.Generator) -> ModelBlob:
    n_in, n_out = int(rng.integers(1, 4)), int(rng.integers(1, 4))
    outs = []
    for _ in range(n_out):
        brs = []
        for _ in range(int(rng.integers(1, 4))):
            brs.append(
                BranchQ(
                    int(rng.integers(0, n_in)),
                    tuple(random_section(rng) for _ in range(int(rng.integers(1, 3)))),
                    random_table(rng) if rng.random() < 0.5 else None,
                    int(rng.integers(0, 16)),
                    int(rng.integers(-32768, 32768)),
                )
            )
        h2 = tuple(random_section(rng) for _ in range(int(rng.integers(1, 3)))) if rng.random() < 0.5 else ()
        outs.append(
            OutputQ(tuple(brs), random_table(rng) if rng.random() < 0.5 else None, h2, int(rng.integers(-32768, 32768)))
        )
    return ModelBlob(n_in, tuple(outs), tuple([1.0] * n_out), int(rng.integers(0, 2**32)))


def designed_blob(rng: np.random.Generator, i: int):
    n_in, n_out = int(rng.integers(1, 4)), int(rng.integers(1, 4))
    kind = KINDS[i % 4]
    s = random_structure(
        rng,
        n_in,
        n_out,
        h1_poles=int(rng.integers(1, 5)),
        h2_poles=int(rng.integers(1, 4)),
        breakpoints=int(rng.integers(2, 11)),
        kind=kind,
    )
    narrow = rng.random() < 0.3  # a range narrower than the data: saturation paths
    rng_in = (-30.0, 0.0) if narrow else None
    u = step_inputs(rng, 2000, n_in)
    # force: a narrow range saturates on purpose (the saturation paths are what is tested)
    return quantize(s, recordings=[("r", u, None)], input_range=rng_in, force=True).blob


def make_cases(seed: int, n_cases: int, n_samples: int):
    """[(blob bytes, inputs int16 (N, 3), estimates int16 (N, 3), flags (N,))]."""
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(n_cases):
        blob = fuzz_blob(rng) if i % 3 == 2 else designed_blob(rng, i)
        if i % 3 == 1:
            blob = compact_tables(blob)  # the quantizer's own tables in the compact encoding
        if i % 3 == 2:
            u = rng.integers(-32768, 32768, (n_samples, 3))
        else:
            u = np.zeros((n_samples, 3))
            u[:, : blob.n_inputs] = step_inputs(rng, n_samples, blob.n_inputs, hold=60) * 100
            spikes = rng.random(n_samples) < 0.01
            u[spikes, 0] = rng.integers(-32768, 32768, int(spikes.sum()))
        u = np.clip(np.round(u), -32768, 32767).astype(np.int64)
        est, flags = FixedPointEstimator(blob).run(u)
        cases.append((blob.to_bytes(), u, est, flags))
    return cases


def write_cases(path: Path, cases, max_len: int = MAX_BLOB_LEN) -> None:
    with open(path, "w") as fh:
        fh.write(f"cases {len(cases)}\n")
        for data, u, est, flags in cases:
            fh.write(f"case {len(data)} {len(u)} {max(max_len, len(data))}\n")
            fh.write(" ".join(f"{b:02x}" for b in data) + "\n")
            for row_u, row_e, fl in zip(u, est, flags):
                fh.write(" ".join(str(int(v)) for v in (*row_u, *row_e, fl)) + "\n")


DATA_FILE = Path(__file__).resolve().parents[1] / "core" / "data" / "estimator_vectors.txt"
SEED, N_CASES, N_SAMPLES = 7, 18, 400


if __name__ == "__main__":  # regenerate the committed vectors after a deliberate format change
    write_cases(DATA_FILE, make_cases(SEED, N_CASES, N_SAMPLES))
    print(f"wrote {DATA_FILE}")
