"""Study: the starting specs `armcal new` writes, rehearsed as a user would - new, simulate, run - for every
library robot with every device (issue 34).

Per case, from the run's results.json (the contract of docs/architecture.md and docs/results.md):
  - held-out RMS: residuals.validation.after.rms, per coordinate, in device.unit;
  - noise: device.noise_sigma, the spec's noise model (what simulate draws); "est." the run's estimate of it
    from the calibration residuals, noise_sigma * sqrt(noise_check.chi2 / noise_check.dof);
  - ratio: held_out_check.rms_over_noise, the held-out RMS in noise sigmas reading by reading (a sonic
    digitizer's sigma grows with the range); the bound is 1.5 (docs/robots.md);
  - cond: identifiability.condition_number (column-scaled base Jacobian at the solution);
  - flat: the base-set problems the run reports: identifiability.flat_directions, .unidentifiable and the
    parameters held as "weakly identifiable" (identifiability.fixed[].reason); "-" when there are none.

Run: .venv/bin/python benchmarks/new_specs_study.py [--robots ur5e,kuka_kr6_r900_sixx] [--devices ballbar,tracker]
(prints one table; 6-29 s a case niced on 2 shared cores, about 15 min for the 84)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from armcal.devices.registry import INSTRUMENTS  # noqa: E402
from armcal.robot_library import names  # noqa: E402

BOUND = 1.5  # held-out RMS over the noise a well-posed starting spec stays within (issue 34)
CONDITION = 1e3  # condition number it stays below: a run reports a direction below 1e-3 of the largest as flat
WEAK = "weakly identifiable"
HEADER = (f"{'robot':24s} {'device':16s} {'exit':>4s} {'held-out RMS':>14s} {'noise':>8s} {'est.':>8s} {'ratio':>6s}"
          f" {'cond':>7s} {'s':>5s}  flat")


@dataclass(frozen=True)
class Case:
    robot: str
    device: str
    exit: int  # armcal run's exit code (0: converged)
    error: str  # the first failing command's stderr tail, "" when all three ran
    results: dict | None
    seconds: float

    def ratio(self) -> float:
        return self.results["held_out_check"]["rms_over_noise"]

    def flat(self) -> list[str]:
        """What the run reports as not determined: flat directions, unidentifiable directions, weak parameters."""
        found = self.results["identifiability"]
        flat = ["+".join(name for name, _ in d["parameters"]) for d in found["flat_directions"]]
        weak = [f["name"] for f in found["fixed"] if f["reason"].startswith(WEAK)]
        return [*flat, *found["unidentifiable"], *weak]

    def row(self) -> str:
        if self.results is None:
            return f"{self.robot:24s} {self.device:16s} {self.exit:4d} failed: {self.error}"
        r, check = self.results, self.results["noise_check"]
        unit, sigma = r["device"]["unit"], r["device"]["noise_sigma"]
        estimated = sigma * (check["chi2"] / check["dof"]) ** 0.5
        held_out = f"{r['residuals']['validation']['after']['rms']:.4g} {unit}"
        return (f"{self.robot:24s} {self.device:16s} {self.exit:4d} {held_out:>14s} {sigma:8.4g} {estimated:8.4g}"
                f" {self.ratio():6.2f} {r['identifiability']['condition_number']:7.1f} {self.seconds:5.0f}  {', '.join(self.flat()) or '-'}")


def armcal(*args, cwd: Path) -> subprocess.CompletedProcess:
    """`python -m armcal ARGS` in ``cwd``, importing this checkout's armcal."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "armcal", *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env)


def rehearse(robot: str, device: str, folder: Path) -> Case:
    """`armcal new`, `simulate`, `run --no-pdf` in ``folder``; the run's results.json."""
    started = time.perf_counter()
    steps = (("new", "--robot", robot, "--device", device, "--out", "cell.yaml"), ("simulate", "cell.yaml", "--out", "."),
             ("run", "cell.yaml", "--no-pdf"))
    for step in steps:
        done = armcal(*step, cwd=folder)
        if done.returncode not in (0, 3):
            return Case(robot, device, done.returncode, f"{step[0]}: {done.stderr.strip()[-300:]}", None, time.perf_counter() - started)
    results = json.loads((folder / "out" / "cell" / "results.json").read_text())
    return Case(robot, device, done.returncode, "", results, time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default=",".join(names()))
    parser.add_argument("--devices", default=",".join(INSTRUMENTS))
    args = parser.parse_args()
    print(HEADER)
    print("-" * len(HEADER))
    for robot in args.robots.split(","):
        for device in args.devices.split(","):
            with tempfile.TemporaryDirectory() as folder:
                print(rehearse(robot, device, Path(folder)).row(), flush=True)
    print(f"held-out RMS: per coordinate; noise: the spec's sigma of one reading (est.: the run's, from the calibration"
          f" residuals); ratio: held-out RMS in noise sigmas reading by reading (bound {BOUND}); cond: condition number (bound {CONDITION:g});"
          " s: seconds; flat: flat directions, unidentifiable directions and parameters held as weakly identifiable")


if __name__ == "__main__":
    main()
