"""The threads the numerical work shares out: the compiled calls of a problem's evaluation (CasADi runs them
without Python's lock) and the row blocks of a Jacobian's QR (LAPACK runs without it too), one share per processor
this process may use (at most MAX_WORKERS). What is cut into items never depends on the number of threads, so the
numbers are the same bit for bit on one thread or four. A process pool's workers (workers.py) divide the
processors among them; BLAS itself stays single-threaded (armcal/__init__.py)."""

from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait
from typing import TypeVar

MAX_WORKERS = 4  # beyond this, the shares of a problem's evaluation are too small to gain from more

Item = TypeVar("Item")
Result = TypeVar("Result")


def processors() -> int:
    """The processors this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


_workers = [max(1, min(MAX_WORKERS, processors()))]


def workers() -> int:
    """How many threads share the work out."""
    return _workers[0]


def limit(count: int) -> None:
    """Use ``count`` threads (a process pool's worker: its part of the processors)."""
    _workers[0] = max(1, min(MAX_WORKERS, count))


@functools.cache
def _pool() -> ThreadPoolExecutor:
    return ThreadPoolExecutor(MAX_WORKERS - 1, thread_name_prefix="armcal")


os.register_at_fork(after_in_child=_pool.cache_clear)  # a forked child has none of the pool's threads
_local = threading.local()


def share() -> int:
    """Which share of the running ``each`` this thread works on (0 outside one): a share's items run one after
    another, so what a share keeps between items (a call's buffers) needs no lock."""
    return getattr(_local, "share", 0)


def each(work: Callable[[Item], Result], items: Sequence[Item]) -> list[Result]:
    """[work(item) for item in items], item k done in share k mod n of n = workers() (this thread the first share,
    the pool's threads the others, at the same time; all in this thread when called from inside a share); an
    exception in any item is raised here once every share has stopped."""
    inside = hasattr(_local, "share")
    n = 1 if inside else min(workers(), len(items))

    def run(k: int) -> list[Result]:
        if inside:  # the items are part of this thread's share
            return [work(item) for item in items]
        _local.share = k
        try:
            return [work(item) for item in items[k::n]]
        finally:
            del _local.share

    others = [_pool().submit(run, k) for k in range(1, n)]
    try:
        shares = [run(0)] if n else []
    finally:
        wait(others)  # no thread still works when this returns or raises
    shares += [other.result() for other in others]
    results: list = [None] * len(items)
    for k, done in enumerate(shares):
        results[k::n] = done
    return results
