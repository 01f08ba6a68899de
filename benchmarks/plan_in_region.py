"""Study: poses planned for the robot's working region against random poses, held-out accuracy in that region.

Issue 17's claim "N planned poses reach the held-out accuracy of at least 3N random poses" failed over the whole
joint range (plan_vs_random.py, docs/plan.md). Here the accuracy that counts is where the robot works:
  - working region: the ISO 9283 cube armcal places (evaluate/working_region.py; the box of the measured point),
    with the poses at the task's orientation (points uniform in the cube solved by inverse kinematics,
    "task") or at any orientation the joints allow (joint-space samples whose point lies in the cube, "any");
  - held-out: 300 such poses (an independent draw); accuracy as in plan_vs_random.py (RMS 3D position error
    of the tracker's target, the calibrated model against the true robot's noise-free readings, mm, mean over
    the simulated robots, the same robots for every design);
  - planned: I-optimal (min trace W M^-1) with W the average position information of 1000 other poses of the
    region's held-out distribution, chosen from the same 2000 candidates uniform over the whole joint range;
    D-optimal (armcal plan's default, region-blind) beside it;
  - random (a): N and 3N of those whole-joint-range candidates (what a user does today);
  - random (b): N and 3N random poses whose point lies in the region, at any orientation (a smarter user; at
    the task's orientation alone the base parameters are not identifiable: M is singular).

Run: .venv/bin/python benchmarks/plan_in_region.py [--runs R] [--robots ur10,kr6] [--orientations task,any] [--region grid]
(prints one table; ~10 min at R = 100 for the ISO cube, docs/plan.md's; ~6 min at R = 30 for the grid)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from armcal.evaluate.plan_accuracy import PlanStudy, accuracy_curve  # noqa: E402
from armcal.evaluate.working_region import working_region  # noqa: E402
from armcal.kinematics.compiler import compile_robot  # noqa: E402
from armcal.spec import load_spec  # noqa: E402

COUNTS = (15, 30, 60)
CANDIDATES = 2000


def specs(folder: Path) -> dict[str, tuple[str, Path]]:
    from plan_vs_random import library_spec

    return {"ur10": ("UR10 tracker", ROOT / "specs" / "ur10.yaml"),
            "kr6": ("KR 6 R900 tracker", library_spec(folder, "kuka_kr6_r900_sixx", "tracker"))}


def worth(planned: float, random: float, random3: float) -> float:
    """How many times N random poses the planned N are worth: log-log interpolation between N and 3N."""
    return float(3 ** (np.log(random / planned) / np.log(random / random3)))


def paired_error(planned: np.ndarray, random: np.ndarray) -> float:
    """Standard error of the ratio of the means planned / random over the robots (first order: the paired
    differences' standard error over the random mean), for the table's I/a3N and I/b3N."""
    return float(np.std(planned - random, ddof=1) / np.sqrt(len(planned)) / np.mean(random))


def study(spec_path: Path, region: str, oriented: bool, runs: int, counts=COUNTS, seed: int = 0):
    loaded = load_spec(spec_path)
    where = working_region(loaded.spec, compile_robot(loaded.spec.robot.chain()), region, oriented)
    plan_study = PlanStudy(loaded.spec, loaded.path.parent, CANDIDATES, seed, criterion="I", region=where)
    curve = accuracy_curve(plan_study, counts, runs, factors=(1, 3), criteria=("I", "D"), region_factors=(1, 3))
    rows = []
    for j, count in enumerate(curve.counts):
        m = {k: float(np.mean(a[:, j])) for k, a in (("I", curve.planned["I"]), ("D", curve.planned["D"]), ("a1", curve.random[1]),
                                                      ("a3", curve.random[3]), ("b1", curve.random_in_region[1]), ("b3", curve.random_in_region[3]))}
        spread = {f"se_{k}3": paired_error(curve.planned["I"][:, j], a[:, j]) for k, a in (("a", curve.random[3]), ("b", curve.random_in_region[3]))}
        rows.append({"N": int(count), **m, **spread, "linearised": float(curve.linearised["I"][j]), "region": where.describe()})
    return rows


def table(rows: list[dict]) -> str:
    lines = [f"{'case':42s} {'N':>3s} {'plan I':>7s} {'plan D':>7s} {'a: N':>7s} {'a: 3N':>7s} {'b: N':>7s} {'b: 3N':>7s} "
             f"{'I/a3N':>11s} {'I/b3N':>11s} {'worth a':>7s} {'worth b':>7s} {'I lin.':>7s}"]
    for r in rows:
        lines.append(f"{r['case']:42s} {r['N']:3d} {r['I']:7.4f} {r['D']:7.4f} {r['a1']:7.4f} {r['a3']:7.4f} {r['b1']:7.4f} {r['b3']:7.4f} "
                     f"{r['I'] / r['a3']:5.2f}+-{r['se_a3']:4.2f} {r['I'] / r['b3']:5.2f}+-{r['se_b3']:4.2f} {worth(r['I'], r['a1'], r['a3']):7.2f} "
                     f"{worth(r['I'], r['b1'], r['b3']):7.2f} {r['linearised']:7.4f}")
    return "\n".join(lines)


def run(runs: int, robots=("ur10", "kr6"), orientations=("task", "any"), region: str = "iso_cube") -> list[dict]:
    out = []
    sys.path.insert(0, str(ROOT / "benchmarks"))
    with tempfile.TemporaryDirectory() as folder:
        cases = specs(Path(folder))
        for robot in robots:
            name, path = cases[robot]
            for orientation in orientations:
                started = time.perf_counter()
                rows = study(path, region, orientation == "task", runs)
                case = f"{name}, {region}, {orientation} orient."
                out += [{"case": case, **r} for r in rows]
                box = rows[0]["region"]
                side = np.array(box["high"]) - np.array(box["low"])
                print(f"# {case}: box {np.round(box['low'])} .. {np.round(box['high'])} mm (sides {np.round(side)}), "
                      f"{time.perf_counter() - started:.0f} s", flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30, help="simulated robots per design")
    parser.add_argument("--robots", default="ur10,kr6")
    parser.add_argument("--orientations", default="task,any")
    parser.add_argument("--region", default="iso_cube", choices=("iso_cube", "grid"))
    args = parser.parse_args()
    rows = run(args.runs, tuple(args.robots.split(",")), tuple(args.orientations.split(",")), args.region)
    print(table(rows))
    print(f"held-out accuracy in the working region, mm, mean over {args.runs} simulated robots (the same for every design); "
          "a: random over the whole joint range, b: random in the region (any orientation); I/a3N <= 1: N planned poses reach 3N random (a); "
          "+-: standard error over the robots (paired); worth: the planned N are as good as worth x N random poses; 'I lin.': sqrt(trace W M^-1) of the I-plan, noise only")


if __name__ == "__main__":
    main()
