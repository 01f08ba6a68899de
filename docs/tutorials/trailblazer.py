"""The Hilti Trailblazer (a Doosan M1013 on a lifting column, measured by a total station) calibrated as a user would.

1. `armcal import-urdf` reads its URDF (base_link to the prism; the column's two mimic joints become the one joint
   the data name, column_prismatic_joint).
2. The spec is completed: the prism is the measured target (its position on the tool free), the total station is a
   3D point device with its datasheet noise, 0.75 mm per coordinate (the data's README).
3. Every data file is converted to armcal's CSV (joints in mm and deg, prism in mm): flat.yaml is the calibration;
   every other file is held out as a new station (the tracked base stands elsewhere), re-registered from its
   stationing points (`use: register`) and predicted at its evaluation points.
4. One `armcal run` per held-out file; the table gives the held-out prism error, nominal (the URDF, re-registered
   the same way) against calibrated, per coordinate and 3D.

The data stay in ../shared/data/hilti-trailblazer (their licence differs from armcal's); nothing is copied into the
project. Run from the project root:  python docs/tutorials/trailblazer.py [--files F ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT.parent / "shared" / "data" / "hilti-trailblazer"
CALIBRATION = "flat"
HELD_OUT = ("pallet", "orthogonal_wood", "wood_left_track", "seesaw", "diagonal_wood", "outdoor")
NOISE_MM = 0.75  # the total station's datasheet noise per coordinate (the data's README)
JOINTS = ("column_prismatic_joint", "dsr_joint1", "dsr_joint2", "dsr_joint3", "dsr_joint4", "dsr_joint5", "dsr_joint6")


def readings(path: Path) -> list[dict]:
    """The waypoints of one data file: joints (m, rad), prism (m), and whether it is a stationing point."""
    data = yaml.safe_load(path.read_text())
    if tuple(data["joint_names"]) != JOINTS:
        raise SystemExit(f"{path}: joint_names are {data['joint_names']}, expected {list(JOINTS)}")
    rows = []
    for height in data["column_heights"].values():
        for space in height["solution_spaces"].values():
            for kind, register in (("stationing_measurements", True), ("evaluation_measurements", False)):
                rows += [dict(q=m["joint_states"], prism=m["prism_position"], register=register) for m in space.get(kind) or []]
    return rows


def csv_text(rows: list[dict], station: str | None) -> str:
    """armcal's tracker CSV (docs/devices/tracker.md): q1 in mm, q2..q7 in deg, x, y, z in mm; held out with
    ``station`` and ``use``."""
    head = [f"q{i}" for i in range(1, 8)] + ["target", "x", "y", "z"] + (["station", "use"] if station else [])
    lines = [",".join(head)]
    for r in rows:
        q = [r["q"][0] * 1000.0] + [float(np.degrees(v)) for v in r["q"][1:]]
        cells = [repr(v) for v in q] + ["prism_centre"] + [repr(v * 1000.0) for v in r["prism"]]
        if station:
            cells += [station, "register" if r["register"] else "evaluate"]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def completed_spec(imported: str, validation: str) -> str:
    """The imported spec with what the data say: the prism as target, the total station, the data files."""
    spec = yaml.safe_load(imported)
    robot = spec["robot"]
    robot["serial"] = "Trailblazer prototype (public data set)"
    tool = robot["tool"]
    robot["targets"] = {"prism_centre": {"link": 7, "x": tool["x"], "y": tool["y"], "z": tool["z"]}}
    # where the total station stands: unknown, identified, started from a rigid registration (docs/devices/tracker.md)
    spec["device"] = {"type": "tracker", "targets": ["prism_centre"], "noise": NOISE_MM,
                      "robot_base": {field: 0 for field in ("x", "y", "z", "rz", "ry", "rx")}}
    spec["procedure"] = {"type": "poses", "count": 444}
    spec["data"] = {"calibration": f"{CALIBRATION}.csv", "validation": f"{validation}.csv"}
    del spec["placeholders"]
    return yaml.safe_dump(spec, sort_keys=False)


def figures(results: dict) -> dict:
    """Held-out prism error (mm), nominal and calibrated: RMS per coordinate and 3D, and the calibration RMS."""
    val, val3 = results["residuals"]["validation"], results["residuals_3d"]["validation"]
    return dict(nominal_rms=val["before"]["rms"], calibrated_rms=val["after"]["rms"],
                nominal_rms_3d=val3["before"]["rms"], calibrated_rms_3d=val3["after"]["rms"],
                held_out_points=val3["after"]["n"], calibration_rms=results["residuals"]["calibration"]["after"]["rms"],
                status=results["status"], added_effects=[f"{e['type']} j{e['joint']}" for e in results["diagnosis"]["added_effects"]],
                implausible=[p["name"] for p in results["plausibility"]["implausible"]],
                largest_correlation=float(np.max(np.abs(results["correlation_matrix"]["matrix"]))))


def armcal(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "armcal", *args], capture_output=True, text=True, cwd=ROOT)


def study(files: list[str], folder: Path) -> dict:
    """Import, convert, run once per held-out file; the figures per file."""
    done = armcal("import-urdf", str(SOURCE / "trailblazer.urdf"), "--base", "base_link", "--tip", "prism",
                  "--out", str(folder / "imported.yaml"))
    if done.returncode:
        raise SystemExit(done.stderr)
    (folder / f"{CALIBRATION}.csv").write_text(csv_text(readings(SOURCE / "datasets" / f"{CALIBRATION}.yaml"), None))
    table = {}
    for name in files:
        (folder / f"{name}.csv").write_text(csv_text(readings(SOURCE / "datasets" / f"{name}.yaml"), name))
        spec = folder / f"{name}.yaml"
        spec.write_text(completed_spec((folder / "imported.yaml").read_text(), name))
        done = armcal("run", str(spec), "--out", str(folder / f"run_{name}"), "--no-pdf")
        if done.returncode:
            raise SystemExit(f"armcal run on {name}: exit {done.returncode}\n{done.stderr}")
        table[name] = figures(json.loads((folder / f"run_{name}" / "results.json").read_text()))
    return table


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="+", default=list(HELD_OUT), choices=HELD_OUT, help="held-out files")
    parser.add_argument("--json", type=Path, help="write the table as JSON")
    args = parser.parse_args()
    if not SOURCE.exists():
        raise SystemExit(f"{SOURCE} is not beside this checkout")
    with tempfile.TemporaryDirectory() as tmp:
        table = study(args.files, Path(tmp))
    print("| held-out file | points | nominal RMS (mm, per coord.) | calibrated | nominal RMS 3D (mm) | calibrated 3D |")
    print("|---|---|---|---|---|---|")
    for name, f in table.items():
        print(f"| {name} | {f['held_out_points']} | {f['nominal_rms']:.2f} | {f['calibrated_rms']:.2f} | "
              f"{f['nominal_rms_3d']:.2f} | {f['calibrated_rms_3d']:.2f} |")
    if args.json:
        args.json.write_text(json.dumps(table, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
