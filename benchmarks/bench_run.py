"""Benchmark: whole commands as a user starts them (fresh process each time), against issue 7's goals.

No peer produces a certificate or runs Stone's study, so the baseline column is the goal:
a whole `armcal run` of the ball-bar example including the PDF under 5 s, and a
Monte-Carlo study of 500 robots under 20 s on this 2-core machine. Each run writes to a
fresh temporary folder; the compiled-function cache is warmed by one untimed run, as on a
user's machine after the first run.

Run: .venv/bin/python benchmarks/bench_run.py   (prints one table; times are medians)
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
CASES = [
    ("ball-bar example, run incl. PDF", ["run", "examples/goswami_ballbar/spec.yaml", "--force"], 5.0, 5),
    ("Monte Carlo, sonic example, 500 robots", ["montecarlo", "examples/puma560_sonic/spec.yaml", "--runs", "500"], 20.0, 3),
]


def _seconds(arguments: list[str]) -> float:
    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        subprocess.run([str(ARMCAL), *arguments, "--out", out], check=True, capture_output=True, cwd=ROOT)
        return time.perf_counter() - started


def main() -> None:
    print(f"{'case':40s} {'armcal s':>9s} {'goal s':>7s} {'ratio':>6s}")
    print("-" * 65)
    for name, arguments, goal, repeats in CASES:
        _seconds(arguments)
        seconds = statistics.median(_seconds(arguments) for _ in range(repeats))
        print(f"{name:40s} {seconds:9.2f} {goal:7.1f} {goal / seconds:6.2f}")
    print("ratio: goal / armcal (above 1 meets the goal); medians of 5 (run) and 3 (Monte Carlo) runs")


if __name__ == "__main__":
    main()
