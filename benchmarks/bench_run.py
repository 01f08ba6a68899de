"""Benchmark: a whole `armcal run` of a shipped example, as a user starts it (fresh process, PDF included).

No peer produces a certificate, so the baseline column is issue 7's goal (5 s for the ball-bar
example). Each run writes to a fresh temporary folder; the compiled-function cache is warmed by
one untimed run, as on a user's machine after the first run.

Run: .venv/bin/python benchmarks/bench_run.py   (prints one table; times are medians of 5 runs)
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ARMCAL = Path(sys.executable).parent / "armcal"
REPEATS = 5
CASES = [("ball-bar example, run incl. PDF", "examples/goswami_ballbar/spec.yaml", 5.0)]


def _run_seconds(spec: str) -> float:
    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        subprocess.run([str(ARMCAL), "run", str(ROOT / spec), "--out", out, "--force"], check=True, capture_output=True)
        return time.perf_counter() - started


def main() -> None:
    print(f"{'case':40s} {'armcal s':>9s} {'goal s':>7s} {'ratio':>6s}")
    print("-" * 65)
    for name, spec, goal in CASES:
        _run_seconds(spec)
        seconds = statistics.median(_run_seconds(spec) for _ in range(REPEATS))
        print(f"{name:40s} {seconds:9.2f} {goal:7.1f} {goal / seconds:6.2f}")
    print("ratio: goal / armcal (above 1 meets the goal)")


if __name__ == "__main__":
    main()
