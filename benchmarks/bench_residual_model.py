"""Benchmark: the learned residual model (diagnose.residual_model: gp, issue 35) on real data, physical only against
physical + learned, and the run's time with and without it.

Cases: the Trailblazer tutorial's study (docs/tutorials/trailblazer.py: calibrate on flat.yaml, each other file held
out at its own re-registered station), one `armcal run` per held-out file with the model and one without; and, with
--ur10, the real UR10 (Series C calibrates, B is held out, as bench_run.py and docs/tutorials/ur10.md: its run with the
model took 261 s of CPU, 11 s without, as long as the six Trailblazer files together, hence behind a flag). Skipped without ../shared/data.

Rows (from results.json's residual_model, mm): "k-fold" is the held-out error on the k-fold folds of the calibration
data (flat.yaml, the same for every Trailblazer file: printed once); every other row is the validation data (the held-out
file's evaluation points, predicted after its station's re-registration: each model's by itself, the physical
model's from the readings, physical + learned's from the readings less the learned correction). "coord": the RMS over
the position coordinates (x, y, z together), "3D": the RMS of the 3D distance; ratio: learned / physical. Seconds: the
armcal process's CPU (user + system; on a shared machine the wall time says more about the other jobs), with the
model and without it.

Run: nice .venv/bin/python benchmarks/bench_residual_model.py [--files F ...] [--ur10]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_run import _ur10_spec  # noqa: E402

_loader = importlib.util.spec_from_file_location("trailblazer", ROOT / "docs" / "tutorials" / "trailblazer.py")
trailblazer = importlib.util.module_from_spec(_loader)
_loader.loader.exec_module(trailblazer)
POSITION = ("x", "y", "z")


def with_model(path: Path) -> Path:
    """A copy of the spec at ``path`` with diagnose.residual_model: gp."""
    spec = yaml.safe_load(path.read_text())
    spec.setdefault("diagnose", {})["residual_model"] = "gp"
    out = path.with_name(path.stem + "_gp.yaml")
    out.write_text(yaml.safe_dump(spec, sort_keys=False))
    return out


def run(spec: Path, out: Path) -> tuple[dict, float]:
    """results.json of one `armcal run` of this checkout (python -m armcal in ROOT, not an installed copy elsewhere) and
    its CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-m", "armcal", "run", str(spec), "--out", str(out), "--no-pdf"], capture_output=True, text=True, cwd=ROOT)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise SystemExit(f"armcal run {spec}: exit {done.returncode}\n{done.stderr}")
    return json.loads((out / "results.json").read_text()), (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def largest_difference(a, b) -> float:
    """The largest relative difference between two results.json blocks' numbers (inf where their shapes differ)."""
    if isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys():
        return max((largest_difference(a[k], b[k]) for k in a), default=0.0)
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return max((largest_difference(u, v) for u, v in zip(a, b)), default=0.0)
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) / max(abs(a), abs(b), 1e-300)
    return 0.0 if a == b else float("inf")


def figures(block: dict) -> dict:
    """Per coordinate (x, y, z and pooled) and 3D RMS, physical and learned, of a residual_model figures block."""
    rows = {r["coordinate"]: r for r in block["per_coordinate"] if r["coordinate"] in POSITION}
    pooled = lambda kind: float(np.sqrt(np.mean([rows[c][kind] ** 2 for c in POSITION])))  # noqa: E731  (equal counts)
    return {"physical": {**{c: rows[c]["physical"] for c in POSITION}, "coord": pooled("physical"), "3D": block["rms_3d_physical"]},
            "learned": {**{c: rows[c]["learned"] for c in POSITION}, "coord": pooled("learned"), "3D": block["rms_3d_learned"]},
            "outside": block["outside"], "readings": block["readings"]}


def case(name: str, spec: Path, folder: Path) -> list[dict]:
    """The table's rows of one case: the k-fold and validation figures of its run with the model, both runs' seconds."""
    plain, seconds_without = run(spec, folder / f"run_{name}")
    learned, seconds_with = run(with_model(spec), folder / f"run_{name}_gp")
    model = learned["residual_model"]
    if learned["residuals"] != plain["residuals"]:  # the model's runs should not change the physical fit
        print(f"{name}: the physical figures differ between the runs with and without the model, by up to "
              f"{largest_difference(learned['residuals'], plain['residuals']):.1e} (relative)", flush=True)
    common = dict(accepted=model["accepted"], z=model["z"], seconds_with=seconds_with, seconds_without=seconds_without,
                  judging=model["seconds"], along=model["folds_along_joint"], hyperparameters=model["hyperparameters"], added=[f"{e['type']} j{e['joint']}" for e in learned["diagnosis"]["added_effects"]])
    rows = [dict(case=f"{name} k-fold", **figures(model["held_out"]), **common)]
    if model["validation"]:
        rows.append(dict(case=f"{name} validation", **figures(model["validation"]), **common))
    return rows


def print_row(row: dict, header: bool = False) -> None:
    if header:
        print(f"{'case':34s} {'what':5s} {'physical':>9s} {'+learned':>9s} {'ratio':>6s} {'outside':>11s} {'accepted':>8s} "
              f"{'z':>6s} {'s with':>7s} {'s w/o':>6s}")
        print("-" * 104)
    z = f"{row['z']:.1f}" if row["case"].endswith("k-fold") else ""  # the test is on the k-fold folds
    for what in ("x", "y", "z", "coord", "3D"):
        p, q = row["physical"][what], row["learned"][what]
        tail = (f"{row['outside']:5d}/{row['readings']:<5d} {str(row['accepted']):>8s} {z:>6s} {row['seconds_with']:7.0f} "
                f"{row['seconds_without']:6.0f}" if what == "3D" else "")
        print(f"{row['case'] if what == 'x' else '':34s} {what:5s} {p:9.3f} {q:9.3f} {q / p:6.3f} {tail}", flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="*", default=list(trailblazer.HELD_OUT), choices=trailblazer.HELD_OUT,
                        help="Trailblazer files held out (default: all six; none with --files alone)")
    parser.add_argument("--ur10", action="store_true", help="add the UR10 (C -> B): about 1,000 s with the model")
    parser.add_argument("--json", type=Path, help="write the rows as JSON")
    args = parser.parse_args()
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.files and trailblazer.SOURCE.exists():
            if trailblazer.armcal("import-urdf", str(trailblazer.SOURCE / "trailblazer.urdf"), "--base", "base_link", "--tip", "prism",
                                  "--out", str(folder / "imported.yaml")).returncode:
                raise SystemExit("armcal import-urdf of the Trailblazer failed")
            flat = trailblazer.readings(trailblazer.SOURCE / "datasets" / f"{trailblazer.CALIBRATION}.yaml")
            (folder / f"{trailblazer.CALIBRATION}.csv").write_text(trailblazer.csv_text(flat, None))
            for i, name in enumerate(args.files):
                held = trailblazer.readings(trailblazer.SOURCE / "datasets" / f"{name}.yaml")
                (folder / f"{name}.csv").write_text(trailblazer.csv_text(held, name))
                spec = folder / f"{name}.yaml"
                spec.write_text(trailblazer.completed_spec((folder / "imported.yaml").read_text(), name))
                found = case(name, spec, folder)
                if i == 0:  # the k-fold figures are flat.yaml's, the same in every run: shown once
                    found[0]["case"] = "Trailblazer flat.yaml k-fold"
                    print_row(found[0], header=True)
                elif found[0]["physical"] != rows[0]["physical"] or found[0]["learned"] != rows[0]["learned"]:
                    print(f"{name}: its run's k-fold figures differ from the first run's", flush=True)
                print_row(found[-1])
                rows += found if i == 0 else found[1:]
        elif args.files:
            print(f"Trailblazer: skipped, {trailblazer.SOURCE} is not beside this checkout")
        if args.ur10:
            spec = _ur10_spec(folder)
            if spec is None:
                print("UR10: skipped, ../shared/data/ipa-robot-accuracy is not beside this checkout")
            else:
                found = case("UR10 C -> B", Path(spec), folder)
                for row in found:
                    print_row(row, header=not rows)
                    rows.append(row)
    print("mm; ratio: learned / physical; outside: readings outside the calibrated region (not corrected); z: the paired "
          "test's change in standard errors on the k-fold folds (accepted below -2); s: CPU seconds of the run with and without the model")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
