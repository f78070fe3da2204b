"""The C++ estimator (tests/core, ASan/UBSan build) against the Python reference, bit for bit."""

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import vectors

from porosense.quant import FixedPointEstimator

CORE_TESTS = Path(__file__).resolve().parents[1] / "core"


def test_committed_vectors_match_the_reference(tmp_path):
    """data/estimator_vectors.txt (run by test_core) is what the Python reference computes now."""
    fresh = tmp_path / "v.txt"
    vectors.write_cases(fresh, vectors.make_cases(vectors.SEED, vectors.N_CASES, vectors.N_SAMPLES))
    assert fresh.read_text() == vectors.DATA_FILE.read_text(), (
        "reference changed: regenerate with `python tests/quant/vectors.py` if intended"
    )


@pytest.mark.xdist_group("core-build")
def test_cpp_estimator_on_fresh_random_models(tmp_path):
    if shutil.which("g++") is None:
        pytest.skip("g++ not installed")
    build = subprocess.run(
        ["make", "-s", "-C", str(CORE_TESTS), "build/test_estimator"], capture_output=True, text=True
    )
    assert build.returncode == 0, build.stderr
    path = tmp_path / "fresh.txt"
    cases = vectors.make_cases(2024, 24, 600)
    vectors.write_cases(path, cases)
    proc = subprocess.run(
        [str(CORE_TESTS / "build" / "test_estimator"), str(path)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "24 cases, 14400 samples bit-exact" in proc.stdout


def test_step_run_and_chunks_agree():
    """One run, chunked runs and single steps carry the same state: identical sequences."""
    case = vectors.make_cases(11, 3, 300)
    for data, u, est, flags in case:
        ref = FixedPointEstimator(data)
        a, fa = ref.run(u)
        assert np.array_equal(a, est) and np.array_equal(fa, flags)
        chunked = FixedPointEstimator(data)
        parts = [chunked.run(u[i : i + 37]) for i in range(0, len(u), 37)]
        assert np.array_equal(np.concatenate([p[0] for p in parts]), est)
        stepper = FixedPointEstimator(data)
        for t in range(50):
            y, f = stepper.step(u[t])
            assert np.array_equal(y, est[t]) and f == flags[t]
        stepper.reset()
        assert np.array_equal(stepper.run(u[:20])[0], est[:20])
