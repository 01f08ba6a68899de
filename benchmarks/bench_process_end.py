"""CPU an `armcal` command's process spends after its exit handlers, with and without the last garbage collection
(armcal/support/process_end.py), from one run: the same commands, alternated, REPEATS times each.

The baseline is the same command with end_without_final_collection made a no-op, so Python collects every object
at exit as it does by default. A probe (a sitecustomize.py that registers the first exit handler, so it runs
last) notes the process's CPU time once every exit handler has run; the process's user + system time (from the
parent's rusage) minus that is its end: what the change removes. Total is the whole process's CPU, which this
machine's speed moves more than the end. Medians of the repeats. Cases: `validate` on the ball-bar example,
`run --no-pdf` and `run` (with the PDF) on it, in a scratch copy, in CasADi's virtual machine (ARMCAL_COMPILE=off)
so no compile falls inside a timing.

    python benchmarks/bench_process_end.py
"""

from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REPEATS = 5
COMMAND = "import armcal.cli as cli, sys\n{patch}cli.app(prog_name='armcal', args=sys.argv[1:])"
VARIANTS = {"armcal": COMMAND.format(patch=""), "baseline": COMMAND.format(patch="cli.end_without_final_collection = lambda: None\n")}
PROBE = "import atexit, os, time\natexit.register(lambda: open(os.environ['EXIT_PROBE'], 'w').write(repr(time.process_time())))\n"


def timed(code: str, args: list[str], cwd: Path, probe: Path) -> tuple[float, float]:
    """(total CPU s, CPU s after the exit handlers) of `python -c code args`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-c", code, *args], cwd=cwd, check=True, capture_output=True,
                   env={**os.environ, "ARMCAL_COMPILE": "off", "PYTHONPATH": f"{probe.parent}{os.pathsep}{ROOT}", "EXIT_PROBE": str(probe)})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return total, total - float(probe.read_text())


def main() -> None:
    with tempfile.TemporaryDirectory() as scratch:
        example, probe = Path(scratch) / "ex", Path(scratch) / "probe" / "cpu_at_exit"
        shutil.copytree(ROOT / "examples" / "goswami_ballbar", example, ignore=shutil.ignore_patterns("out"))
        probe.parent.mkdir()
        (probe.parent / "sitecustomize.py").write_text(PROBE)
        cases = {"validate (ball-bar example)": ["validate", "spec.yaml"],
                 "run --no-pdf (ball-bar, virtual machine)": ["run", "spec.yaml", "--out", "out", "--force", "--no-pdf"],
                 "run with PDF (ball-bar, virtual machine)": ["run", "spec.yaml", "--out", "out", "--force"]}
        print(f"CPU s per process, median of {REPEATS}; end: after the exit handlers")
        print(f"{'case':42s} {'armcal end':>10s} {'baseline end':>12s} {'ratio':>6s} {'armcal total':>12s} {'baseline total':>14s}")
        for case, args in cases.items():
            runs: dict[str, list[tuple[float, float]]] = {name: [] for name in VARIANTS}
            for _ in range(REPEATS):
                for name, code in VARIANTS.items():
                    runs[name].append(timed(code, args, example, probe))
            (total_a, end_a), (total_b, end_b) = ([statistics.median(v) for v in zip(*runs[name])] for name in VARIANTS)
            print(f"{case:42s} {end_a:10.2f} {end_b:12.2f} {end_b / end_a:6.1f} {total_a:12.2f} {total_b:14.2f}")


if __name__ == "__main__":
    main()
