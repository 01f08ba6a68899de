"""Run independent tasks on a local process pool, or on a Dask distributed cluster.

Both backends return the results in the order of the tasks, whatever order they
finish in, so a study or a fleet gives the same results whichever ran it. Workers
are fresh processes (spawned, not forked) that import armcal themselves; each
task must be a picklable top-level function and its arguments.
"""

from __future__ import annotations

import re
import socket
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from typing import Any

from armcal.support.errors import UserError
from armcal.support.process_end import end_without_final_collection
from armcal.identify.threads import limit, processors

Progress = Callable[[Any], None]  # called with each result as it arrives
MAX_PROCESSES = 256  # local worker processes (--workers): each is a Python with armcal and CasADi, ~150 MB


def check_workers(workers: int | None) -> None:
    """A user error, before any work, when ``workers`` (None: one per processor) is no number of local worker
    processes from 1 to MAX_PROCESSES."""
    if workers is not None and not 1 <= workers <= MAX_PROCESSES:
        raise UserError(f"--workers {workers}: give a number of local worker processes from 1 to {MAX_PROCESSES} "
                        "(default: one per processor; a Dask cluster, --scheduler, for more)")


def run_tasks(
    function: Callable, tasks: Sequence, scheduler: str | None = None, workers: int | None = None, progress: Progress | None = None
) -> list:
    """[function(task) for task in tasks], run in parallel; ``scheduler`` is a Dask scheduler's address."""
    report = progress or (lambda result: None)
    check_workers(workers)
    if scheduler is not None:
        check_scheduler_address(scheduler)
        return _on_dask(function, tasks, scheduler, report)
    workers = min(workers or processors(), len(tasks))  # one worker per processor by default
    if workers <= 1:
        results = []
        for task in tasks:
            results.append(function(task))
            report(results[-1])
        return results
    results: list = [None] * len(tasks)
    shares = max(1, processors() // workers)  # each worker's threads (identify/threads.py): its part of the processors
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=_start_worker, initargs=(shares,)) as pool:
        position = {pool.submit(function, task): i for i, task in enumerate(tasks)}
        try:
            for future in as_completed(position):
                results[position[future]] = future.result()
                report(results[position[future]])
        except BaseException:
            pool.shutdown(cancel_futures=True)  # a failed task stops the rest at once
            raise
    return results


def _start_worker(shares: int) -> None:
    """A local worker process: its share of the processors' threads, and no last collection at its exit."""
    limit(shares)
    end_without_final_collection()


SCHEDULER_ADDRESS = re.compile(r"(?:(?:tcp|tls|ws|wss)://)?(?:\[(?P<ipv6>[0-9A-Fa-f:.]+)\]|(?P<host>[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?)):(?P<port>\d{1,5})")


def check_scheduler_address(scheduler: str) -> None:
    """A Dask scheduler address [protocol://]host:port, refused at once when it is not one."""
    match = SCHEDULER_ADDRESS.fullmatch(scheduler.strip())
    if match is None or not 0 < int(match["port"]) < 65536:
        raise UserError(f"--scheduler {scheduler!r} is not a scheduler address; give [tcp://]HOST:PORT, e.g. tcp://10.0.0.5:8786")


CONNECT_TIMEOUT = 10.0  # s: a scheduler that takes longer to accept a connection counts as unreachable


def _reachable(scheduler: str) -> None:
    """A user error at once when nothing accepts a connection at the scheduler's host and port (a refused port
    would otherwise keep the Dask client retrying until its timeout)."""
    match = SCHEDULER_ADDRESS.fullmatch(scheduler.strip())
    try:
        socket.create_connection((match["ipv6"] or match["host"], int(match["port"])), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        raise UserError(f"cannot reach the Dask scheduler at {scheduler} ({exc.strerror or exc})") from None


def _on_dask(function: Callable, tasks: Sequence, scheduler: str, report: Progress) -> list:
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:
        raise UserError("--scheduler needs Dask's distributed scheduler client: pip install 'armcal[dask]'") from None
    _reachable(scheduler)
    try:
        client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT:.0f}s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"cannot reach the Dask scheduler at {scheduler} ({exc})") from None
    with client:
        futures = client.map(_on_one_thread, [function] * len(tasks), list(tasks), pure=False)
        position = {future.key: i for i, future in enumerate(futures)}
        results: list = [None] * len(tasks)
        for future in dask_completed(futures, loop=client.loop):
            results[position[future.key]] = future.result()
            report(results[position[future.key]])
    return results


def _on_one_thread(function: Callable, task: Any) -> Any:
    """A Dask task: a worker runs several at once, one per thread, so each keeps to its own (identify/threads.py)."""
    limit(1)
    return function(task)
