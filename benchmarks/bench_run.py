"""Benchmark: whole commands as a user starts them (fresh process each time), against issues 7's and 33's goals.

No peer produces a certificate or runs Stone's study, so the baseline column is the goal:
a whole `armcal run` of the ball-bar example including the PDF under 5 s, a Monte-Carlo
study of 500 robots under 20 s on this 2-core machine, and the real UR10's closed loop
(calibrate on Series C, hold out Series B, diagnosis on, no PDF) in 5 s of CPU (issue 33;
skipped without ../shared). Each run writes to a fresh temporary folder; the
compiled-function cache is warmed by one untimed run that compiles every library
(ARMCAL_COMPILE=now), as on a user's machine once the libraries have paid for themselves. CPU is the child process's user + system time: on a loaded machine the wall
time says more about the other jobs than about armcal.

Run: .venv/bin/python benchmarks/bench_run.py   (prints one table; times are medians)
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ARMCAL = Path(sys.executable).parent / "armcal"
SERIES = ROOT.parent / "shared" / "data" / "ipa-robot-accuracy"
WARM_UP = {**os.environ, "ARMCAL_COMPILE": "now"}  # the untimed run builds every library the timed runs use


def _ur10_spec(folder: Path) -> str | None:
    """specs/ur10.yaml with Series C to calibrate and Series B held out, imported into ``folder``; None without the data."""
    if not SERIES.exists():
        return None
    for series in ("C", "B"):
        source = next((SERIES / f"Series_{series}").glob("measurements_*.csv"))
        subprocess.run([str(ARMCAL), "import-ipa", "specs/ur10.yaml", str(source), "--out", str(folder / f"{series}.csv")],
                       check=True, capture_output=True, cwd=ROOT)
    text = (ROOT / "specs" / "ur10.yaml").read_text().replace("armcal: 1\n", "armcal: 1\ndata: {calibration: C.csv, validation: B.csv}\n", 1)
    (folder / "spec.yaml").write_text(text)
    return str(folder / "spec.yaml")


def _seconds(arguments: list[str], environment: dict | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of one armcal process."""
    with tempfile.TemporaryDirectory() as out:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        subprocess.run([str(ARMCAL), *arguments, "--out", out], check=True, capture_output=True, cwd=ROOT, env=environment)
        wall = time.perf_counter() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    with tempfile.TemporaryDirectory() as data:
        ur10 = _ur10_spec(Path(data))
        cases = [
            ("ball-bar example, run incl. PDF", ["run", "examples/goswami_ballbar/spec.yaml", "--force"], "wall", 5.0, 5),
            ("Monte Carlo, sonic example, 500 robots", ["montecarlo", "examples/puma560_sonic/spec.yaml", "--runs", "500"], "wall", 20.0, 3),
        ]
        if ur10:
            cases.append(("UR10 C -> B, closed loop, no PDF", ["run", ur10, "--no-pdf"], "CPU", 5.0, 3))
        print(f"{'case':40s} {'armcal s':>9s} {'goal s':>7s} {'ratio':>6s}  measure")
        print("-" * 75)
        for name, arguments, measure, goal, repeats in cases:
            _seconds(arguments, WARM_UP)
            times = [_seconds(arguments) for _ in range(repeats)]
            seconds = statistics.median(t[0] if measure == "wall" else t[1] for t in times)
            print(f"{name:40s} {seconds:9.2f} {goal:7.1f} {goal / seconds:6.2f}  {measure}")
        if not ur10:
            print("UR10 closed loop: skipped, ../shared/data/ipa-robot-accuracy is not beside this checkout")
    print("ratio: goal / armcal (above 1 meets the goal); medians of 5 (run), 3 (Monte Carlo) and 3 (UR10) runs")


if __name__ == "__main__":
    main()
