"""Where the candidates of a search run: a local process pool (the default) or any
concurrent.futures Executor, a Dask ``distributed.Client`` among them, with progress, a cost
estimate and a prompt stop on Ctrl-C.

Local workers ignore SIGINT: the terminal sends Ctrl-C to the whole process group, and the
main process alone decides what happens (it cancels what is queued and terminates the workers,
so an interrupted search stops within a second instead of finishing every running fit).
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, ParamSpec, TypeVar

_P = ParamSpec("_P")
_T = TypeVar("_T")

# Seconds between wake-ups of the main process while it waits for workers (the progress
# display's clock and the reaction time to Ctrl-C).
POLL_SECONDS = 1.0


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def local_pool(max_workers: int | None = None) -> ProcessPoolExecutor:
    """A process pool over ``max_workers`` (default: every core) whose workers ignore Ctrl-C."""
    return ProcessPoolExecutor(max_workers=max_workers or os.cpu_count() or 1, initializer=_ignore_sigint)


def stop(executor) -> None:
    """Cancel what is queued on ``executor`` and, for a local process pool, terminate its
    workers at once (shutdown alone would wait for every running fit)."""
    if executor is None:
        return
    if isinstance(executor, ProcessPoolExecutor):
        # The pool keeps its processes in a private mapping (Python < 3.14 has no public
        # terminate_workers); terminating them is the only way not to wait for running fits.
        processes = list((getattr(executor, "_processes", None) or {}).values())
        executor.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            if p.is_alive():
                p.terminate()
        for p in processes:
            p.join(timeout=2.0)
    else:
        try:
            executor.shutdown(wait=False, cancel_futures=True)
        except TypeError:  # executors without cancel_futures
            executor.shutdown(wait=False)


@dataclass
class Cluster:
    """The executor a search submits to, with what it needs to ship data: a Dask client
    scatters the records once to every worker instead of sending them with every task."""

    executor: Executor
    client: Any = None  # distributed.Client, when the executor is its
    workers: int = 1
    own: bool = False  # created here: stopped here

    @classmethod
    def resolve(cls, executor, tasks: int = 2) -> Cluster:
        """``executor``: None (a local pool over the cores, or this process for one task), a
        concurrent.futures Executor, or a ``distributed.Client`` (its executor is used)."""
        if executor is None:
            if tasks <= 1:
                return cls(_InProcess(), workers=1, own=True)
            n = min(os.cpu_count() or 1, tasks)
            return cls(local_pool(n), workers=n, own=True)
        if hasattr(executor, "get_executor") and hasattr(executor, "scatter"):
            client = executor
            n = max(sum(w.get("nthreads", 1) for w in client.scheduler_info(n_workers=-1)["workers"].values()), 1)
            return cls(client.get_executor(pure=False), client=client, workers=n)
        n = getattr(executor, "_max_workers", None) or os.cpu_count() or 1
        return cls(executor, workers=int(n))

    def share(self, data):
        """``data`` as the workers receive it: scattered once to a Dask cluster, else as is."""
        if self.client is None:
            return data
        return self.client.scatter(data, broadcast=True, hash=False)

    def close(self, interrupted: bool = False) -> None:
        if interrupted:
            stop(self.executor)
        elif self.own:
            self.executor.shutdown()


class _InProcess(Executor):
    """Runs each task in this process at submission (one task needs no pool)."""

    def submit(self, fn: Callable[_P, _T], /, *args: _P.args, **kwargs: _P.kwargs) -> Future[_T]:
        fut: Future[_T] = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # KeyboardInterrupt included: raised where it is waited for
            if isinstance(exc, KeyboardInterrupt):
                raise
            fut.set_exception(exc)
        return fut


@dataclass
class Task:
    """One unit of work: ``fn(*args)`` and its expected cost in arbitrary units (``weight``)."""

    fn: Callable
    args: tuple
    weight: float = 1.0


@dataclass
class Progress:
    """What a search reports while it runs (passed to the ``progress`` callback).

    ``done`` and ``total`` count tasks of the current stage; ``eta_seconds`` is the wall time
    left for the whole search estimated from the CPU time of the tasks finished so far (None
    until one has finished); ``workers`` the number of workers it assumes.
    """

    stage: str
    done: int
    total: int
    elapsed_seconds: float
    eta_seconds: float | None = None
    workers: int = 1
    candidates_done: int = 0


@dataclass
class Runner:
    """Submits tasks to a :class:`Cluster`, collects their results in submission order and keeps
    a cost model (CPU seconds per unit of weight) for the estimate of the time left."""

    cluster: Cluster
    report: Callable | None = None
    planned: float = 0.0  # weight of the work still to come after the current stage
    weight_done: float = 0.0
    cpu_done: float = 0.0
    started: float = field(default_factory=time.perf_counter)
    candidates_done: int = 0

    def eta(self, pending_weight: float) -> float | None:
        if self.weight_done <= 0 or self.cpu_done <= 0:
            return None
        rate = self.cpu_done / self.weight_done
        return (pending_weight + self.planned) * rate / max(self.cluster.workers, 1)

    def run(self, stage: str, tasks: list[Task], cpu_of: Callable = lambda r: 0.0) -> list:
        """Results of ``tasks`` in their order; ``cpu_of(result)`` the CPU seconds a result
        reports (for the cost model). A KeyboardInterrupt stops the cluster's work and propagates."""
        futures = [self.cluster.executor.submit(t.fn, *t.args) for t in tasks]
        index = {f: i for i, f in enumerate(futures)}
        results: list = [None] * len(tasks)
        pending = set(futures)
        pending_weight = sum(t.weight for t in tasks)
        self._report(stage, 0, len(tasks), pending_weight)
        while pending:
            done, pending = wait(pending, timeout=POLL_SECONDS, return_when=FIRST_COMPLETED)
            for f in done:
                i = index[f]
                results[i] = f.result()
                pending_weight -= tasks[i].weight
                self.weight_done += tasks[i].weight
                self.cpu_done += max(float(cpu_of(results[i])), 0.0)
                self.candidates_done += len(results[i]) if isinstance(results[i], list) else 1
            self._report(stage, len(tasks) - len(pending), len(tasks), pending_weight)
        return results

    def _report(self, stage, done, total, pending_weight):
        if self.report is not None:
            self.report(
                Progress(
                    stage,
                    done,
                    total,
                    time.perf_counter() - self.started,
                    self.eta(pending_weight),
                    self.cluster.workers,
                    self.candidates_done,
                )
            )
