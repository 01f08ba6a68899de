"""The threads the numerical work shares out: the compiled calls of a problem's evaluation (CasADi runs them
without Python's lock) and the row blocks of a Jacobian's QR (LAPACK runs without it too) go side by side, one
share per processor this process may use (at most MAX_WORKERS). A process pool's workers (parallel.py) divide
the processors among them instead; BLAS itself stays single-threaded (armcal/__init__.py)."""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

MAX_WORKERS = 4  # beyond this, the shares of a problem's evaluation are too small to gain from more

Share = TypeVar("Share")
Result = TypeVar("Result")


def processors() -> int:
    """The processors this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


_workers = [max(1, min(MAX_WORKERS, processors()))]


def workers() -> int:
    """How many shares the work is cut into."""
    return _workers[0]


def limit(count: int) -> None:
    """Use ``count`` workers (a process pool's worker: its part of the processors)."""
    _workers[0] = max(1, min(MAX_WORKERS, count))


@functools.cache
def _pool() -> ThreadPoolExecutor:
    return ThreadPoolExecutor(MAX_WORKERS - 1, thread_name_prefix="armcal")


os.register_at_fork(after_in_child=_pool.cache_clear)  # a forked child has none of the pool's threads


def side_by_side(work: Callable[[Share], Result], shares: Sequence[Share]) -> list[Result]:
    """``work(share)`` for each share, the first in this thread and the others in the pool's threads, at the same
    time; the results in the shares' order (an exception in any share is raised here)."""
    if len(shares) > MAX_WORKERS:
        raise ValueError(f"{len(shares)} shares for at most {MAX_WORKERS} workers")
    others = [_pool().submit(work, share) for share in shares[1:]]
    return [work(share) for share in shares[:1]] + [other.result() for other in others]
