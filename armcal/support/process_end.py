"""How a process that runs one command ends: without a last garbage collection over its objects.

When Python exits, it collects every object it still tracks: the imported modules (NumPy, SciPy, CasADi,
Matplotlib, WeasyPrint) and whatever the command built, the CasADi graphs of its models among them. The
operating system takes the process's memory back at once anyway; that last collection only spends
CPU, 0.6-2.7 s per command on the shipped ball-bar example (benchmarks/bench_process_end.py: a quarter
of `armcal validate`'s CPU, a tenth of a `run`'s). Objects left to the operating system this way are not finalized
by the collector; armcal closes its files and builds its output set before a command returns
(support/output_set.py), and Python's exit handlers (atexit) run as before.
"""

from __future__ import annotations

import atexit
import gc


def end_without_final_collection() -> None:
    """At this process's exit, keep the collector off every object then alive (gc.freeze): the last collection
    over them all is left out. Once per process however often it is called (a test runs many commands in one)."""
    atexit.unregister(gc.freeze)
    atexit.register(gc.freeze)
