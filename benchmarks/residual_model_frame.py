"""Experiment (issue 35): the Trailblazer's outdoor file held out, the learned residual model's corrections as armcal
applies them (in the calibration station's instrument frame) against the same corrections turned into the held-out
station's frame. The turn is the relative rotation of two rigid registrations (tests/rigid_fit.py's Kabsch) of the
URDF's prism (yourdfpy, tests/urdf_oracle.py) onto each file's measured points; nothing of it is in armcal.

Run from the project root (about a minute of CPU):  python benchmarks/residual_model_frame.py
"""

import atexit
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]

import numpy as np  # noqa: E402
import yaml  # noqa: E402
import urdf_oracle  # noqa: E402
from bench_residual_model import trailblazer as tb  # noqa: E402
from rigid_fit import kabsch  # noqa: E402

from armcal.commands.run import fitted_device  # noqa: E402
from armcal.dataio.reader import read_measurements  # noqa: E402
from armcal.diagnose.calibration import identify_and_diagnose  # noqa: E402
from armcal.kinematics.compiler import compile_robot  # noqa: E402
from armcal.spec import load_spec  # noqa: E402

HELD_OUT = "outdoor"


def rotation(name: str) -> np.ndarray:
    """The instrument's rotation from the robot's base_link, registered on every point of a file (the URDF's prism)."""
    rows = tb.readings(tb.SOURCE / "datasets" / f"{name}.yaml")
    prism = urdf_oracle.poses(urdf_oracle.load(tb.SOURCE / "trailblazer.urdf"), np.array([r["q"] for r in rows]), ["prism"], "base_link")
    return kabsch(prism["prism"][:, :3, 3], np.array([r["prism"] for r in rows]) * 1000.0)[:3, :3]


def main() -> None:
    folder = Path(tempfile.mkdtemp())
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "armcal", "import-urdf", str(tb.SOURCE / "trailblazer.urdf"), "--base", "base_link",
                    "--tip", "prism", "--out", str(folder / "imported.yaml")], check=True, capture_output=True, cwd=ROOT)
    (folder / "flat.csv").write_text(tb.csv_text(tb.readings(tb.SOURCE / "datasets" / "flat.yaml"), None))
    (folder / f"{HELD_OUT}.csv").write_text(tb.csv_text(tb.readings(tb.SOURCE / "datasets" / f"{HELD_OUT}.yaml"), HELD_OUT))
    spec = yaml.safe_load(tb.completed_spec((folder / "imported.yaml").read_text(), HELD_OUT))
    spec.setdefault("diagnose", {})["residual_model"] = "gp"
    (folder / "spec.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    s = load_spec(folder / "spec.yaml").spec
    raw = read_measurements(folder / s.data.calibration, s)
    device = fitted_device(s, raw)
    validation = device.prepare(read_measurements(folder / s.data.validation, s))
    c = identify_and_diagnose(s, compile_robot(s.robot), device, raw, device.prepare(raw), validation)
    r, _ = c.validation.evaluate(c.identified.theta)
    change, _ = c.residual.model.correction(c.validation, np.nan_to_num(validation.q))
    res, points = c.validation.residuals, {}
    for i, (sample, key, channel) in enumerate(zip(res.sample, res.key, res.channel)):
        if sample >= 0 and channel in ("x", "y", "z"):
            points.setdefault((int(sample), str(key)), {})[channel] = (r[i] * res.sigma[i], change[i] * res.sigma[i])
    physical = np.array([[p[c][0] for c in "xyz"] for p in points.values()])
    learned = np.array([[p[c][1] for c in "xyz"] for p in points.values()])
    turn = rotation(HELD_OUT) @ rotation("flat").T  # the calibration station's frame into the held-out one's
    print(f"{HELD_OUT}: {len(physical)} points; RMS mm: x, y, z, per coordinate, 3D")
    for name, error in (("physical", physical), ("+ learned, as applied", physical + learned), ("+ learned, turned", physical + learned @ turn.T)):
        per = np.sqrt(np.mean(error**2, axis=0))
        print(f"{name:24s} {per[0]:6.3f} {per[1]:6.3f} {per[2]:6.3f} {np.sqrt(np.mean(error**2)):6.3f} {np.sqrt(np.mean(np.sum(error**2, axis=1))):6.3f}")


if __name__ == "__main__":
    main()
