"""Benchmark (issue 18): what a user waits for on a first run, a repeated run and a run after a value edit.

For each shipped example (examples/*/spec.yaml), `armcal run --no-pdf` in a fresh process, three times
on one private, initially empty compiled-code cache (ARMCAL_CACHE):
  cold    the cache is empty (a new robot or instrument);
  warm    the same spec again;
  edited  the spec with its device noise changed by 1 % (0.0084 -> 0.008484 on the ball-bar).
"before" is the armcal of git revision --before (default: main), extracted with `git archive`
into a temporary folder; "after" is this checkout. Each runs with the environment as given
(ARMCAL_COMPILE unset: the command's default; since auto, a library is built only once the work done with it pays
for the compile, so a warm run may still evaluate in the virtual machine). CPU is user + system time of the armcal process
and of the children it waited for (main's compiler runs): a background build is not counted
there; its own column says how long after the run the library was in place (the next run
waits for nothing). Before each timed run the background builds of the previous one are
finished, so no run competes with a compiler. libs: compiled libraries in the cache after the
three runs; same: the largest difference of any identified parameter value (results.json)
of the version's cold, warm and edited runs against before's, in units of its std.

Run: .venv/bin/python benchmarks/bench_first_run.py [--before REV] [--examples NAME ...]
(one table; about 5 minutes on 2 cores)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ("goswami_ballbar", "hidden_harmonic", "puma560_sonic", "theodolite")
NOISE = re.compile(r"(\n  noise: (?:\{a: )?)([0-9.]+(?:e-?[0-9]+)?)")


def edited(text: str) -> str:
    """The spec with its device's (first) noise value 1 % larger."""
    return NOISE.sub(lambda m: m.group(1) + repr(round(float(m.group(2)) * 1.01, 12)), text, count=1)


def checkout(revision: str, folder: Path) -> Path:
    """The armcal package of ``revision`` extracted into ``folder`` (git archive: no worktree, nothing written to the repository)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", revision, "armcal"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    return folder


def timed_run(code: Path, spec: Path, out: Path, cache: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one `armcal run` in a fresh process."""
    env = {**os.environ, "PYTHONPATH": str(code), "ARMCAL_CACHE": str(cache)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    # cwd: the example's folder, as a user runs it; `python -m` puts the cwd first on sys.path, so run from a checkout
    # it would import that checkout's armcal instead of PYTHONPATH's
    done = subprocess.run([sys.executable, "-m", "armcal", "run", str(spec), "--out", str(out), "--no-pdf", "--force"],
                          capture_output=True, text=True, env=env, cwd=spec.parent)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 3):
        raise RuntimeError(f"armcal run {spec} failed ({done.returncode}):\n{done.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def builds_finished(cache: Path, timeout: float = 600.0) -> float:
    """Seconds until no background build is left in ``cache`` (its build-* folders are gone)."""
    started = time.perf_counter()
    while any(cache.glob("build-*")) and time.perf_counter() - started < timeout:
        time.sleep(0.1)
    return time.perf_counter() - started


def parameters(out: Path) -> dict[str, tuple[float, float]]:
    results = json.loads((out / "results.json").read_text())
    return {p["name"]: (p["value"], p["std"] or 0.0) for p in results["parameters"]}


def difference(a: dict, b: dict) -> float:
    """Largest |value difference| / std over the parameters both runs identified."""
    return max((abs(a[n][0] - b[n][0]) / a[n][1] for n in a if n in b and a[n][1] > 0), default=0.0)


def measure(code: Path, example: str, work: Path) -> dict:
    folder = work / example
    shutil.copytree(ROOT / "examples" / example, folder, ignore=shutil.ignore_patterns("out"))
    (folder / "edited.yaml").write_text(edited((folder / "spec.yaml").read_text()))
    assert (folder / "edited.yaml").read_text() != (folder / "spec.yaml").read_text(), example
    cache = Path(tempfile.mkdtemp(dir=work, prefix="cache-"))
    row = {}
    for name, spec in (("cold", "spec.yaml"), ("warm", "spec.yaml"), ("edited", "edited.yaml")):
        row[name] = timed_run(code, folder / spec, folder / f"out-{name}", cache)
        row[f"{name} build"] = builds_finished(cache)
        row[f"{name} parameters"] = parameters(folder / f"out-{name}")
    row["libs"] = len(list(cache.glob("*.so")))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", default="main", help="git revision of the 'before' armcal (default: main)")
    parser.add_argument("--examples", nargs="*", default=EXAMPLES)
    options = parser.parse_args()
    header = (f"{'case':16s} {'version':7s} {'cold wall':>9s} {'cold CPU':>8s} {'bg build':>8s} {'warm wall':>9s} {'warm CPU':>8s}"
              f" {'edit wall':>9s} {'edit CPU':>8s} {'libs':>4s} {'same':>8s}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory(prefix="armcal-bench-") as temporary:
        work = Path(temporary)
        versions = {"before": checkout(options.before, work / "before"), "after": ROOT}
        for example in options.examples:
            rows = {version: measure(code, example, work / version) for version, code in versions.items()}
            for version, row in rows.items():
                same = max(difference(rows["before"][f"{name} parameters"], row[f"{name} parameters"]) for name in ("cold", "warm", "edited"))
                print(
                    f"{example:16s} {version:7s} {row['cold'][0]:9.2f} {row['cold'][1]:8.2f} {row['cold build']:8.2f}"
                    f" {row['warm'][0]:9.2f} {row['warm'][1]:8.2f} {row['edited'][0]:9.2f} {row['edited'][1]:8.2f}"
                    f" {row['libs']:4d} {same:8.1e}"
                )
    print("s; CPU: user + system of the run and the children it waited for; bg build: s from the cold run's end until its")
    print("background build was in place (not in the run's CPU); libs: libraries in the cache after the three runs; same: largest")
    print("|parameter difference| / std of the version's cold, warm and edited runs against before's same runs (results.json)")


if __name__ == "__main__":
    main()
