"""Benchmark: `armcal plan` and `armcal montecarlo` on the UR10 at their default sizes, against the revision before
issue 33 (goal 3: halve both).

The baseline is armcal as it was before issue 33's first change (BASELINE), exported from this repository's history
into a temporary folder and run from there on the same spec, in the same run of this script. Each command runs once
untimed with ARMCAL_COMPILE=now (every library it uses compiled and cached, as on a user's machine once they have
paid for themselves), then REPEATS times; the table
gives the median CPU seconds (the process and the worker processes it waits for: on a loaded machine the wall time
says more about the other jobs than about armcal) and the wall seconds beside them.

Run: .venv/bin/python benchmarks/bench_plan_montecarlo.py   (prints one table)
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BASELINE = "706c6fb^"  # the parent of issue 33's first commit
REPEATS = 3
CASES = (
    ("plan, UR10, 50 poses of 2000 candidates, 50 robots", ["plan", "specs/ur10.yaml", "--poses", "50", "--out", "{out}/poses.csv"]),
    ("montecarlo, UR10, 500 robots", ["montecarlo", "specs/ur10.yaml", "--out", "{out}/study"]),
)


def _exported(revision: str, folder: Path) -> Path:
    """The package of ``revision`` written into ``folder`` (git archive of armcal/)."""
    archive = folder / "baseline.tar"
    subprocess.run(["git", "archive", "--output", str(archive), revision, "armcal"], check=True, cwd=ROOT)
    with tarfile.open(archive) as tar:
        tar.extractall(folder, filter="data")
    return folder


def _seconds(arguments: list[str], package: Path, compile_mode: str | None = None) -> tuple[float, float]:
    """(CPU, wall) seconds of one armcal process importing armcal from ``package`` (``compile_mode``: its
    ARMCAL_COMPILE, else the environment's)."""
    with tempfile.TemporaryDirectory() as out:
        command = [sys.executable, "-m", "armcal", *(a.format(out=out) for a in arguments)]
        environment = {**os.environ, "PYTHONPATH": str(package), **({"ARMCAL_COMPILE": compile_mode} if compile_mode else {})}
        before, started = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
        subprocess.run(command, check=True, capture_output=True, cwd=ROOT, env=environment)
        wall, after = time.perf_counter() - started, resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def _median(arguments: list[str], package: Path) -> tuple[float, float]:
    _seconds(arguments, package, "now")  # warm: every library it uses compiled
    times = [_seconds(arguments, package) for _ in range(REPEATS)]
    return statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)


def main() -> None:
    with tempfile.TemporaryDirectory() as scratch:
        baseline = _exported(BASELINE, Path(scratch))
        print(f"{'case':52s} {'armcal CPU s':>12s} {'baseline CPU s':>14s} {'ratio':>6s} {'armcal wall s':>13s} {'baseline wall s':>15s}")
        print("-" * 118)
        for name, arguments in CASES:
            cpu, wall = _median(arguments, ROOT)
            cpu_before, wall_before = _median(arguments, baseline)
            print(f"{name:52s} {cpu:12.1f} {cpu_before:14.1f} {cpu_before / cpu:6.2f} {wall:13.1f} {wall_before:15.1f}")
    print(f"ratio: baseline CPU / armcal CPU (2 or more meets issue 33's goal 3); medians of {REPEATS} warm runs; baseline: {BASELINE}")


if __name__ == "__main__":
    main()
