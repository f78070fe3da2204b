"""Known systems (float estimator structures) and the recordings they produce."""

from __future__ import annotations

import numpy as np
import pytest

from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

TS = 0.02


def _g():
    return PiecewiseLinear(np.array([-2.0, -0.8, 0.0, 0.7, 2.5]), np.array([-1.2, -0.9, 0.0, 1.4, 1.7]))


def truth_system(kind: str) -> EstimatorStructure:
    """SISO truths of each kind; two poles in total so the grid poles 1..2 contains them."""
    if kind == "linear":
        out = OutputChain("y", (Branch(0, SOSCascade.from_tf([0.05, 0.04], [1.0, -1.5, 0.62])),), offset=0.5)
    elif kind == "hammerstein":
        out = OutputChain("y", (Branch(0, SOSCascade.from_tf([0.05, 0.04], [1.0, -1.5, 0.62]), f=_g()),), offset=0.5)
    elif kind == "wiener":
        out = OutputChain("y", (Branch(0, SOSCascade.from_tf([0.05, 0.04], [1.0, -1.5, 0.62])),), g=_g(), offset=0.5)
    elif kind == "wh":
        out = OutputChain(
            "y",
            (Branch(0, SOSCascade.from_tf([0.3], [1.0, -0.7])),),
            g=_g(),
            h2=SOSCascade.from_tf([0.15], [1.0, -0.85]),
            offset=0.5,
        )
    else:  # pragma: no cover
        raise ValueError(kind)
    return EstimatorStructure(("u",), (out,), ts=TS)


def excitation(n: int, seed: int) -> np.ndarray:
    """Random steps (held 25 samples) plus a little white noise, spanning -2.4..2.4."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-2.4, 2.4, n // 25 + 1), 25)[:n]
    return (u + 0.15 * rng.standard_normal(n))[:, None]


def recordings(system: EstimatorStructure, n: int, seeds, snr_db: float | None = None):
    """(inputs, noisy outputs, noise-free outputs) per seed; noise at ``snr_db`` (power ratio)."""
    us, ys, clean = [], [], []
    for seed in seeds:
        u = excitation(n, seed)
        y0 = system.simulate(u)[:, 0]
        y = y0.copy()
        if snr_db is not None:
            rng = np.random.default_rng(1000 + seed)
            sigma = np.std(y0) / 10 ** (snr_db / 20)
            y = y0 + sigma * rng.standard_normal(n)
        us.append(u)
        ys.append(y)
        clean.append(y0)
    return us, ys, clean


@pytest.fixture(scope="session")
def truth():
    return truth_system


@pytest.fixture(scope="session")
def make_recordings():
    return recordings


@pytest.fixture(scope="session")
def shared_data():
    """The measured benchmark folder: POROSENSE_SHARED_DATA, else <repo>/../shared/data, else
    /work/shared/data; skip with the reason when none exists."""
    from porosense.bench.ident import shared_data_folder

    folder = shared_data_folder()
    if folder is None:
        pytest.skip("measured benchmark data not found (POROSENSE_SHARED_DATA, ../shared/data, /work/shared/data)")
    return folder
