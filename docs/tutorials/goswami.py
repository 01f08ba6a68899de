"""Goswami, Quaid & Peshkin (1993) reproduced with armcal, side by side with their numbers.

1. Identifiable parameters of their PUMA 560 (six-parameter model, 54 parameters) for
   subsets of the nine ball-bar pairings, with and without encoder scales: armcal's count
   (rank of the Jacobian, Goswami's test: "the number of linearly independent columns of
   ... J"), the count the formula predicts, and the number their text reports.
2. Calibration of the shipped example (examples/goswami_ballbar: SIMULATED readings, bar
   noise set to their residual level) through armcal's pipeline: RMS residual on the 46 cm
   calibration shells and on the held-out 61 cm shells, next to their measured 0.084 mm
   and 0.110 mm.

Run from the project root:  python docs/tutorials/goswami.py [--json FILE]
Exit status 1 when a count disagrees with the formula or with the paper; else 0.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.identify.identifiability import analyse
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import compile_robot
from armcal.commands.run import run
from armcal.simulate import find_truth
from armcal.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "examples" / "goswami_ballbar" / "spec.yaml"

ALL = [(f"chuck{c}", f"sphere{s}") for c in (1, 2, 3) for s in (1, 2, 3)]
# (label, pairings, the count Goswami's text gives for it with encoder scales, or None).
# Their Table I lists pairing subsets and counts; its prose ("Pose Measurements: How Many
# Dimensions Are Enough?") states: all nine pairings 36; "any six of these nine pairings are
# sufficient, so long as no steel sphere or magnetic chuck is uninvolved"; one sphere
# measured from all three chucks 33.
CASES = [
    ("all nine pairings", ALL, 36),
    ("six, every chuck and sphere used", [("chuck1", "sphere1"), ("chuck1", "sphere2"), ("chuck2", "sphere2"), ("chuck2", "sphere3"), ("chuck3", "sphere3"), ("chuck3", "sphere1")], 36),
    ("six, sphere3 unused", [p for p in ALL if p[1] != "sphere3"], None),
    ("four, chucks 1-2 x spheres 1-2", [p for p in ALL if p[0] != "chuck3" and p[1] != "sphere3"], None),
    ("three, chuck i with sphere i", [("chuck1", "sphere1"), ("chuck2", "sphere2"), ("chuck3", "sphere3")], None),
    ("one sphere, three chucks", [p for p in ALL if p[1] == "sphere1"], 33),
    ("one sphere, two chucks", [("chuck1", "sphere1"), ("chuck2", "sphere1")], None),
    ("one pairing", [("chuck1", "sphere1")], None),
]
GOSWAMI_RMS_MM = {"calibration": 0.084, "validation": 0.110}  # "Results and Discussion": 46 cm fit, 61 cm held out

# Rigid rotations no distance measurement can see, by the number of (non-collinear) points
# involved: any rotation about one point (3), the rotation about the line through two (1).
UNSEEN_ROTATIONS = {1: 3, 2: 1, 3: 0}


def formula(n_revolute: int, n_prismatic: int, scales: bool, chucks: int, spheres: int) -> int:
    """Goswami (1): N = 5 n_r + 3 n_p + 6 with encoder scales, 4 n_r + 2 n_p + 6 without,
    less the rotations about the pivots (world side) and about the spheres (flange side)
    that leave every measured distance unchanged."""
    n = 5 * n_revolute + 3 * n_prismatic + 6 if scales else 4 * n_revolute + 2 * n_prismatic + 6
    return n - UNSEEN_ROTATIONS[chucks] - UNSEEN_ROTATIONS[spheres]


def counts() -> tuple[list[dict], dict]:
    """armcal's count for every case: rank of the Jacobian at the nominal over the 54 (48) robot parameters."""
    loaded = load_spec(SPEC)
    spec = loaded.spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    data = device.prepare(read_measurements(SPEC.parent / spec.data.calibration, spec))
    problem = build_problem(kinematics, device, data)
    _, J = problem.evaluate(problem.parameters.nominal)  # noise-free: the Jacobian does not depend on the readings
    names = problem.parameters.names
    robot = np.array([n.split(".")[0].startswith(("L", "j")) for n in names])  # the 7 links' and 6 joints' 54
    scale = np.array([n.endswith(".k") for n in names])
    n_r = kinematics.joint_types.count("revolute")
    n_p = kinematics.joint_types.count("prismatic")
    pairing = [key[:2] for key in problem.residuals.key]
    rows_out = []
    for label, pairs, goswami in CASES:
        rows = np.array([p in pairs for p in pairing])
        chucks, spheres = len({p[0] for p in pairs}), len({p[1] for p in pairs})
        row = {"case": label, "pairs": [list(p) for p in pairs], "chucks": chucks, "spheres": spheres, "poses": int(rows.sum()), "goswami": goswami}
        for tag, free in (("scales", robot), ("no_scales", robot & ~scale)):
            found = analyse(J[rows], problem.parameters, free, hold_weak=False)  # the rank: Goswami's count, whatever the noise
            row[f"armcal_{tag}"] = found.rank
            row[f"condition_{tag}"] = found.condition_number
            row[f"formula_{tag}"] = formula(n_r, n_p, tag == "scales", chucks, spheres)
            row[f"parameters_{tag}"] = int(free.sum())
        rows_out.append(row)
    own = analyse(J, problem.parameters, problem.parameters.free, hold_weak=False)  # the spec's free set: Goswami's Table II choice
    spec_choice = {"free": int(problem.parameters.free.sum()), "rank": own.rank, "redundant": [n for n, why in own.fixed if why.startswith("redundant")]}
    return rows_out, spec_choice


def calibration() -> dict:
    """armcal run on the shipped example (into a temporary folder): RMS on both sets of shells."""
    loaded = load_spec(SPEC)
    spec = loaded.spec
    simulated = find_truth(SPEC.parent / spec.data.calibration) is not None  # truth.json of `armcal simulate` matches the data
    sigma = spec.device.noise * (spec.simulate.noise_factor if spec.simulate else 1.0)  # mm (loaded specs are in mm)
    with tempfile.TemporaryDirectory() as out:
        results = run(SPEC, Path(out), force=True, pdf=False).results
    assert results.device.unit == "mm", results.device.unit
    residuals = results.residuals
    return {
        "simulated": simulated,
        "noise_sigma_mm": sigma,
        "status": results.status,
        "identified": results.identifiability.rank,
        "chi2_per_dof": results.noise_check.chi2 / results.noise_check.dof,
        "added_effects": len(results.diagnosis.added_effects),
        **{
            name: {
                "samples": stats.after.n,
                "rms_before_mm": stats.before.rms,
                "rms_mm": stats.after.rms,
                "goswami_mm": GOSWAMI_RMS_MM[name],
            }
            for name, stats in (("calibration", residuals.calibration), ("validation", residuals.validation))
        },
    }


def show(rows: list[dict], spec_choice: dict, fit: dict) -> list[str]:
    """Print the tables; return the disagreements."""
    problems = []
    print("Identifiable parameters, PUMA 560 six-parameter model (Goswami Table I; formula (1))")
    print(f"Jacobian at the design values, the {rows[0]['poses']} poses of the 46 cm calibration shells\n")
    print(f"{'':34}{'':>8}{'':>8} | {'with encoder scales (54)':^34} | {'without (48)':^15}".rstrip())
    print(f"{'pairings':34}{'chucks':>8}{'spheres':>8} | {'armcal':>7}{'formula':>8}{'Goswami':>9}{'cond.':>9} | {'armcal':>7}{'formula':>8}")
    for r in rows:
        paper = "-" if r["goswami"] is None else str(r["goswami"])
        print(f"{r['case']:34}{r['chucks']:>8}{r['spheres']:>8} | {r['armcal_scales']:>7}{r['formula_scales']:>8}{paper:>9}{r['condition_scales']:>9.0f} | {r['armcal_no_scales']:>7}{r['formula_no_scales']:>8}")
        for tag in ("scales", "no_scales"):
            if r[f"armcal_{tag}"] != r[f"formula_{tag}"]:
                problems.append(f"{r['case']} ({tag}): armcal {r[f'armcal_{tag}']}, formula {r[f'formula_{tag}']}")
        if r["goswami"] is not None and r["armcal_scales"] != r["goswami"]:
            problems.append(f"{r['case']}: armcal {r['armcal_scales']}, Goswami {r['goswami']}")
    print(f"\nThe spec's {spec_choice['free']} free parameters (Table II, 18 held fixed): rank {spec_choice['rank']}"
          f"{', redundant: ' + ', '.join(spec_choice['redundant']) if spec_choice['redundant'] else ', none redundant'}")
    if spec_choice["rank"] != spec_choice["free"]:
        problems.append(f"the spec's free set has rank {spec_choice['rank']} < {spec_choice['free']}")

    kind = "simulated by armcal simulate" if fit["simulated"] else "NOT from armcal simulate"
    print(f"\nCalibration of examples/goswami_ballbar: armcal's data {kind} (bar noise sigma {fit['noise_sigma_mm']:.3f} mm);")
    print("Goswami's are measured on a real PUMA 560")
    print(f"{'RMS residual, mm':34}{'samples':>8}{'before':>9}{'armcal':>9}{'Goswami':>9}")
    for name, label in (("calibration", "46 cm shells (calibration)"), ("validation", "61 cm shells (held out)")):
        s = fit[name]
        print(f"{label:34}{s['samples']:>8}{s['rms_before_mm']:>9.3f}{s['rms_mm']:>9.4f}{s['goswami_mm']:>9.3f}")
    m, p = fit["calibration"]["samples"], fit["identified"]
    print(f"{fit['status']}, {p} parameters identified, chi2/dof {fit['chi2_per_dof']:.3f}, effects added by the diagnosis: {fit['added_effects']}")
    print(f"noise alone would leave sigma*sqrt(1 - p/M) = {fit['noise_sigma_mm'] * np.sqrt(1 - p / m):.4f} mm on the calibration shells")
    print("\ncheck: " + ("every count agrees with the formula and the paper" if not problems else "DISAGREEMENTS: " + "; ".join(problems)))
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the numbers to this file")
    arguments = parser.parse_args()
    rows, spec_choice = counts()
    fit = calibration()
    problems = show(rows, spec_choice, fit)
    if arguments.json:
        arguments.json.write_text(json.dumps({"counts": rows, "spec_choice": spec_choice, "calibration": fit, "problems": problems}, indent=1) + "\n")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
