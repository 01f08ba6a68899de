"""Benchmark: armcal compensate on 20,000 targets (issue 33, goal 2: at most 5 s CPU and 300 MB), against the code before.

The robot: specs/ur10.yaml with a gear harmonic on joint 2 and an encoder scale on joint 3 (the commands then differ
from the joints the chain needs, as on a calibrated robot). The targets: the tool at joint configurations drawn here,
rows without seeds, so each row starts from the solution of the row before it:
- one path: a program's continuous motion, the joints along a smooth path through random waypoints;
- paths of 200: the same number of targets in paths of 200 that start anywhere (each start far from the last end);
- scattered: random configurations, each target far from the one before it (1,000 targets: the chain cannot be
  batched there, and the code before takes minutes).
Each side runs in a fresh process that imports everything and reads the targets first; what is reported is the CPU
time of compensate and its peak resident set above the resident set at that point. The baseline is the code of
BASELINE (main before issue 33's goal 2), checked out by git into a temporary folder. The compiled functions are
built by one untimed run first, as on a user's machine after the first run.

Both sides' statuses and commands are compared row by row, and so are the baseline's own for the targets moved by
MOVE_MM: a control. Where a path crosses a singularity, or rows near one are unreachable and the
next starts from the middle of the limits, which far root Newton-Raphson lands on hangs on the last bits of its start
(the block's guess, 1e-6 at most from the predecessor's solution) and of the arithmetic (the order of a sum); the rows
after it then follow another branch. The control shows the code before does the same.

Run: .venv/bin/python benchmarks/bench_compensate.py   (prints one table; takes several minutes)
"""

from __future__ import annotations

import csv
import io
import json
import os
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BASELINE = "6bd52b0"  # main before issue 33's goal 2
HARMONIC = "effects:\n  - {type: gear_harmonic, joint: 2, order: 1, sin: 0.05 deg, cos: -0.03 deg}\n  - {type: encoder_scale, joint: 3, scale: 0.0004}\n"
CASES = [("one path", 20_000), ("paths of 200", 20_000), ("scattered", 1_000)]
PATH_POSES, LEG_POSES, LEG_DEG = 200, 200, 30  # poses of a separate path; poses and largest joint move of a leg
SAME_JOINTS = 1e-7  # deg: both sides' commands (written to 12 digits) agree within the solver's tolerance
MOVE_MM = 1e-9  # the control's move of the targets: far below any tolerance
BRANCH_STEP_DEG = 20  # a step between neighbouring commands larger than any path's here (at most 0.25 deg): a change of branch
MIB = 1024.0  # KiB per MiB


def _configurations(case: str, count: int):
    """Joint configurations (count, 6) in rad: the elbow bent to one side (30-150 deg) and the wrist away from its
    singularity (joint 5 at 20-160 deg); a path moves each joint by up to LEG_DEG between waypoints LEG_POSES apart."""
    import numpy as np

    rng = np.random.default_rng(33)
    low, high = np.deg2rad([-150, -150, 30, -150, 20, -150]), np.deg2rad([150, 150, 150, 150, 160, 150])
    if case == "scattered":
        return rng.uniform(low, high, (count, 6))
    steps = (1 - np.cos(np.linspace(0, np.pi, LEG_POSES + 1)))[:-1, None] / 2  # the leg's poses, its end excluded

    def path(poses: int) -> np.ndarray:
        waypoints = [rng.uniform(low, high)]
        while len(waypoints) * LEG_POSES < poses + 1:
            waypoints.append(np.clip(waypoints[-1] + rng.uniform(-1, 1, 6) * np.deg2rad(LEG_DEG), low, high))
        return np.vstack([a + steps * (b - a) for a, b in zip(waypoints[:-1], waypoints[1:])])[:poses]

    return path(count) if case == "one path" else np.vstack([path(PATH_POSES) for _ in range(count // PATH_POSES)])


def _write_inputs(folder: Path, case: str, count: int) -> None:
    """calibrated.yaml and targets.csv of a case in ``folder``."""
    import numpy as np

    from armcal.kinematics.compiler import compile_robot
    from armcal.kinematics.transforms import pose_from_matrix
    from armcal.spec import load_spec

    (folder / "calibrated.yaml").write_text((ROOT / "specs" / "ur10.yaml").read_text().replace("armcal: 1\n", f"armcal: 1\n{HARMONIC}", 1))
    kinematics = compile_robot(load_spec(folder / "calibrated.yaml").spec.robot.chain())
    lines = ["name,x,y,z,rx,ry,rz"]
    for i, T in enumerate(kinematics.tool_poses(_configurations(case, count))):
        x, y, z, rz, ry, rx = pose_from_matrix(T)
        lines.append(",".join([f"t{i}", *(repr(float(v)) for v in (x, y, z, *np.rad2deg([rx, ry, rz])))]))
    (folder / "targets.csv").write_text("\n".join(lines) + "\n")


def _resident_kib() -> int:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:"))


def child(folder: Path, source: Path) -> dict:
    """In a fresh process, armcal imported from ``source``: compensate the folder's targets; CPU s and MiB above the
    resident set after the imports and the reading."""
    sys.meta_path = [finder for finder in sys.meta_path if not type(finder).__module__.startswith("__editable__")]  # the venv's armcal
    sys.path.insert(0, str(source))
    from armcal.export.compensation import compensate
    from armcal.spec import load_spec

    loaded, text = load_spec(folder / "calibrated.yaml"), (folder / "targets.csv").read_text()
    before, started = _resident_kib(), time.process_time()
    commands, unreached, _ = compensate(loaded, None, text, "targets.csv")
    seconds, peak = time.process_time() - started, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    (folder / f"commands_{sys.argv[2]}.csv").write_text(commands)
    return {"seconds": seconds, "work": (peak - before) / MIB, "total": peak / MIB, "armcal": sys.modules["armcal"].__file__}


def measure(side: str, source: Path, folder: Path) -> dict:
    environment = {"ARMCAL_COMPILE": os.environ.get("ARMCAL_COMPILE", "now"), "PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    out = subprocess.run([sys.executable, __file__, str(folder), side, str(source)], check=True, capture_output=True, text=True, env=environment).stdout
    return json.loads(out.splitlines()[-1])


def _commands(path: Path):
    import numpy as np

    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    return [r["status"] for r in rows], np.array([[float(r[f"q{j}"] or "nan") for j in range(1, 7)] for r in rows])


def _moved(folder: Path, moved: Path) -> Path:
    """A copy of a case's inputs with every target's x moved by MOVE_MM: the control for results that hang on the
    last bits (the code before, on targets no instrument tells apart)."""
    moved.mkdir()
    (moved / "calibrated.yaml").write_text((folder / "calibrated.yaml").read_text())
    header, *rows = (folder / "targets.csv").read_text().splitlines()
    cells = [row.split(",") for row in rows]
    (moved / "targets.csv").write_text("\n".join([header, *(",".join([c[0], repr(float(c[1]) + MOVE_MM), *c[2:]]) for c in cells)]) + "\n")
    return moved


def _differ(status, joints, other_status, other) -> int:
    """Rows of another status or whose commands differ by more than SAME_JOINTS (rows without commands on both sides
    agree in their commands)."""
    import numpy as np

    apart = np.abs(joints - other).max(axis=1) > SAME_JOINTS
    return int(np.sum(apart | (np.isnan(joints) != np.isnan(other)).any(axis=1) | (np.array(status) != np.array(other_status))))


def _branch_changes(joints) -> int:
    """Rows whose command moves some joint more than BRANCH_STEP_DEG from the row before (both reached)."""
    import numpy as np

    return int(np.sum(np.abs(np.diff(joints, axis=0)).max(axis=1) > BRANCH_STEP_DEG))


def _checked_out(revision: str, folder: Path) -> Path:
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "armcal"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    return folder


def main() -> None:
    import numpy as np

    header = (f"{'case':24s} {'targets':>7s} {'armcal s':>8s} {'before s':>8s} {'ratio':>6s} {'armcal MiB':>10s} {'before MiB':>10s} {'ratio':>6s}"
              f" {'armcal peak':>11s} {'before peak':>11s}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as scratch:
        before = _checked_out(BASELINE, Path(scratch) / "before")
        for case, count in CASES:
            folder = Path(scratch) / case.replace(" ", "_")
            folder.mkdir()
            _write_inputs(folder, case, count)
            measure("armcal", ROOT, folder)  # builds the compiled functions: untimed
            armcal, baseline = measure("armcal", ROOT, folder), measure("before", before, folder)
            moved = _moved(folder, Path(scratch) / f"{folder.name}_moved")
            measure("before", before, moved)
            (status_a, joints_a), (status_b, joints_b) = _commands(folder / "commands_armcal.csv"), _commands(folder / "commands_before.csv")
            status_m, joints_m = _commands(moved / "commands_before.csv")
            print(
                f"{case:24s} {count:7d} {armcal['seconds']:8.2f} {baseline['seconds']:8.2f} {baseline['seconds'] / armcal['seconds']:6.1f}"
                f" {armcal['work']:10.0f} {baseline['work']:10.0f} {baseline['work'] / max(armcal['work'], 1.0):6.1f}"
                f" {armcal['total']:11.0f} {baseline['total']:11.0f}"
            )
            print(f"    rows off before's (another status, or commands more than {SAME_JOINTS:g} deg apart): {_differ(status_a, joints_a, status_b, joints_b)} now,"
                  f" {_differ(status_m, joints_m, status_b, joints_b)} before for the targets moved by {MOVE_MM:g} mm (of {count}; {status_b.count('ok')} ok before)")
            print(f"    changes of branch (a step over {BRANCH_STEP_DEG} deg): {_branch_changes(joints_a)} now, {_branch_changes(joints_b)} before,"
                  f" {_branch_changes(joints_m)} before for the moved targets")
    print("s: CPU seconds of compensate; MiB: peak resident set above the process's after imports and reading the targets;")
    print("peak: the whole process's peak resident set, MiB (imports, the spec and the targets' text included);")
    print(f"before: the code of {BASELINE}; ratio: before / armcal")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        print(json.dumps(child(Path(sys.argv[1]), Path(sys.argv[3]))))
    else:
        main()
