"""One BLAS thread while identification and the simulator's calibration fit and score.

A fit makes thousands of small products: p x p normal equations, dot products over one
record, (n_breakpoints x n_breakpoints) times (n_breakpoints x N) sensitivities. OpenBLAS runs
each of them on all its threads once it passes a few thousand elements, and waking and
synchronising those threads costs more than the product; on a shared 2-core machine (or with
a process pool already on every core) the threads wait for each other. Measured on the demo's
order search (5 recordings, 19,250 samples, 24 candidates, in one process at load average 7-9):
77 s of CPU time with OpenBLAS's 2 threads, 30 s with one, the same models; the simulator's
material calibration (porosense.sim.calibrate) 14.4 -> 5.4 s, the same fit.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

_P = ParamSpec("_P")
_T = TypeVar("_T")

_controller = None  # threadpoolctl.ThreadpoolController, made at first use (after scipy loads its BLAS)


def one_thread():
    """A context manager holding every loaded BLAS library (numpy's and scipy's) at one thread."""
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")


def single_threaded(fn: Callable[_P, _T]) -> Callable[_P, _T]:
    """``fn`` run under :func:`one_thread` (keeps its name, so process pools pickle it by name)."""

    @functools.wraps(fn)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _T:
        with one_thread():
            return fn(*args, **kwargs)

    return wrapper
