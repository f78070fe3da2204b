"""Fits and diagnoses reuse the memory they free (porosense.dsp.heap)."""

import platform
import resource

import numpy as np
import pytest

from porosense import ident
from porosense.dsp import heap


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc's mallopt only")
def test_repeated_fits_reuse_freed_memory_instead_of_faulting_pages_in():
    """Page faults of a second Wiener fit on 2 x 20,000 samples: each Jacobian makes arrays of a
    few hundred kB; mapped afresh, each fit faults its pages in again (measured 22,600 per fit
    without the setting), reused, none once the heap has grown (measured 0 from the second fit
    on). Bound: under 2,000, far from both."""
    assert heap.keep_freed_memory()
    rng = np.random.default_rng(0)
    us = [rng.standard_normal((20_000, 1)) for _ in range(2)]
    ys = [np.tanh(np.convolve(u[:, 0], [0.5, 0.3, 0.1])[: len(u)]) for u in us]

    def fit():
        ident.Wiener(n_poles=2, n_zeros=1, n_breakpoints=6, starts=1, max_nfev=10).fit(u=us, y=ys, ts=1.0)

    fit()  # the heap grows to the fit's size once
    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    fit()
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
    print("page faults of the second fit:", faults)
    assert faults < 2_000


def test_the_setting_is_made_once_per_process(monkeypatch):
    first = heap.keep_freed_memory()
    calls = []
    monkeypatch.setattr("ctypes.CDLL", lambda *a: calls.append(a))
    assert heap.keep_freed_memory() == first and not calls
