"""A terminal line for every stage of a command that takes longer than a second (issue 18): what it is, said once
the second has passed, and how long it took when it ends. Stages under a second say nothing.

Lines go to standard error, beside the compile notes of support/compiled.py (which say that a compile happens once).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

LONG = 1.0  # s: a stage that runs longer is said


def _say(line: str) -> None:
    print(f"armcal: {line}", file=sys.stderr, flush=True)


@contextmanager
def stage(what: str) -> Iterator[None]:
    """Say ``what`` is running once it has taken LONG seconds, and its time when it ends."""
    started = time.perf_counter()
    timer = threading.Timer(LONG, _say, (f"{what} ...",))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        took = time.perf_counter() - started
        if took > LONG:
            _say(f"{what}: {took:.1f} s")
