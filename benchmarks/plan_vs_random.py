"""Study: N planned poses (armcal plan) against N and 3N random poses, held-out accuracy on simulated robots.

Issue 17, item 2's claim to test: "N planned poses reach the held-out accuracy of at least 3N random poses".
Cases: a UR-like arm (specs/ur10.yaml: UR10, tracker with orientation) and a KUKA-like arm (KR 6 R900 sixx
from the robot library, `armcal new --robot kuka_kr6_r900_sixx --device tracker`) with a laser tracker, at
N = 15, 30, 60; and the KUKA with a ball-bar (`armcal new ... --device ballbar`, its three pivots and three
spheres) at N = 60, 120, 240: a ball-bar pose gives one reading, and the ball-bar's 36 base parameters need
more than 36 readings, so N = 15 and 30 cannot be identified at all.

Held-out accuracy (evaluate/plan_accuracy.py): RMS over 300 independent held-out candidate poses of the
calibrated model's position-reading error against the true robot's noise-free readings (3D target position
for the tracker, bar length for the ball-bar), mm; mean over the simulated robots, the same robots for every
design (common random numbers). Random poses are drawn from the same readable candidates the plan chooses
from (uniform in the joint limits; random shell points for the ball-bar). "planned D" is what armcal plan
uses; "planned I" the I-optimal alternative (min average prediction variance at held-out poses).

Run: .venv/bin/python benchmarks/plan_vs_random.py [--runs R] [--plots DIR]   (prints one table; ~8 min at R = 100)
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
from armcal.commands.new import new_spec_text  # noqa: E402
from armcal.report.plan_plots import accuracy_plot  # noqa: E402
from armcal.robot_library import library_robot  # noqa: E402
from armcal.spec import load_spec  # noqa: E402

TRACKER_COUNTS = (15, 30, 60)
BALLBAR_COUNTS = (60, 120, 240)
CANDIDATES = {"tracker": 2000, "ballbar": 3000}  # the ball-bar's: about 55 % reachable, enough for 3 x 240


def library_spec(folder: Path, robot: str, device: str) -> Path:
    """The spec `armcal new --robot ROBOT --device DEVICE` writes."""
    path = folder / f"{robot}-{device}.yaml"
    path.write_text(new_spec_text(library_robot(robot), device, path.stem))
    return path


def cases(folder: Path) -> list[tuple[str, Path, tuple[int, ...], str]]:
    return [
        ("UR10 tracker", ROOT / "specs" / "ur10.yaml", TRACKER_COUNTS, "tracker"),
        ("KR 6 R900 tracker", library_spec(folder, "kuka_kr6_r900_sixx", "tracker"), TRACKER_COUNTS, "tracker"),
        ("KR 6 R900 ball-bar", library_spec(folder, "kuka_kr6_r900_sixx", "ballbar"), BALLBAR_COUNTS, "ballbar"),
    ]


def study_case(spec_path: Path, counts, device: str, runs: int, seed: int = 0):
    loaded = load_spec(spec_path)
    study = PlanStudy(loaded.spec, loaded.path.parent, CANDIDATES[device], seed)
    return study, accuracy_curve(study, counts, runs, factors=(1, 3), criteria=("D", "I"))


def leverage_ratio(blocks: np.ndarray) -> float:
    """max over the candidates of trace(A_i W^-1 A_i^T), W their average information, over its mean p: the most any
    design can divide the average prediction variance of many random poses by (AM-HM on the eigenvalues of
    W^-1/2 M W^-1/2, whose trace no design of normalised information M can raise above the largest leverage)."""
    W = np.einsum("nkp,nkq->pq", blocks, blocks) / len(blocks)
    leverage = np.einsum("nkp,pq,nkq->n", blocks, np.linalg.inv(W), blocks)
    return float(leverage.max() / leverage.mean())


def mean(values: np.ndarray) -> float:
    """Mean over the robots; NaN when any robot's design could not be identified."""
    return float(np.mean(values))


def table(rows: list[dict]) -> str:
    header = (f"{'case':20s} {'N':>4s} {'planned D':>10s} {'planned I':>10s} {'random N':>10s} {'random 3N':>10s} {'D/rand 3N':>10s} "
              f"{'D/rand N':>9s} {'worth':>6s} {'D lin.':>8s}")
    lines = [header]
    for r in rows:
        lines.append(f"{r['case']:20s} {r['N']:4d} {r['D']:10.4f} {r['I']:10.4f} {r['random']:10.4f} {r['random3']:10.4f} "
                     f"{r['D'] / r['random3']:10.2f} {r['D'] / r['random']:9.2f} {worth(r):6.2f} {r['linearised']:8.4f}")
    return "\n".join(lines)


def worth(row: dict) -> float:
    """How many times N random poses the planned N are worth: log-log interpolation of the random accuracy
    between N and 3N poses (above 3 or below 1: extrapolated)."""
    return float(3 ** (np.log(row["random"] / row["D"]) / np.log(row["random"] / row["random3"])))


def run(runs: int, plots: Path | None = None) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, spec, counts, device in cases(Path(folder)):
            started = time.perf_counter()
            study, curve = study_case(spec, counts, device, runs)
            for j, count in enumerate(curve.counts):
                rows.append({"case": name, "N": int(count), "D": mean(curve.planned["D"][:, j]), "I": mean(curve.planned["I"][:, j]),
                             "random": mean(curve.random[1][:, j]), "random3": mean(curve.random[3][:, j]),
                             "linearised": float(curve.linearised["D"][j]), "base": len(study.information.base),
                             "readable": study.pool})
            if plots is not None:
                plots.mkdir(parents=True, exist_ok=True)
                title = f"{name}, mean over {runs} simulated robots"
                (plots / f"{name.replace(' ', '_').replace(',', '')}.svg").write_text(accuracy_plot(curve.values(), "mm", title))
            print(f"# {name}: {study.pool} readable candidates of {CANDIDATES[device]}, {len(study.information.base)} base parameters, "
                  f"largest leverage / mean leverage {leverage_ratio(study.information.blocks):.2f}, {time.perf_counter() - started:.0f} s", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100, help="simulated robots per design")
    parser.add_argument("--plots", type=Path, help="a folder for one SVG per case: accuracy against N")
    args = parser.parse_args()
    rows = run(args.runs, args.plots)
    print(table(rows))
    print(f"held-out accuracy in mm, mean over {args.runs} simulated robots (the same for every design); "
          "D/rand 3N < 1: N planned poses beat 3N random ones; worth: the planned N are as good as worth x N random poses; "
          "'D lin.': sqrt(trace W M^-1) of the planned design, noise only")


if __name__ == "__main__":
    main()
