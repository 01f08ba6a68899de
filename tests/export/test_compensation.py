"""armcal compensate on a simulated true robot with a hidden effect (tests/independent_sim.py, not armcal's
simulator): a UR-like arm measured by a tracker, joint 2 with a gear harmonic the spec does not declare. After the
calibration (the diagnosis adds the harmonic), targets the true robot reaches at fresh configurations are commanded
three ways, and the true robot is sent to each command: the compensated commands reach the targets within the
tracker's noise; the nominal model's miss by the calibration's improvement factor; the calibrated geometry without
its effect misses by the harmonic."""

import csv
import io

import numpy as np
import pytest
from independent_sim import TRACKER, readings, sample_configurations, write_campaign
from rigid_fit import kabsch
from ruamel.yaml import YAML

from armcal.export.compensation import compensate
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.transforms import pose_from_matrix, xyz_zyx
from armcal.commands.run import run
from armcal.spec import load_spec

ROBOT, DEVICE, TARGETS = "ur_like", "tracker", 60


def _with_tool_at_smr(path, out, drop_effects=False):
    """The spec with its tool frame moved to the reflector (its calibrated or nominal position): compensate's tool."""
    yaml = YAML()
    root = yaml.load(path.read_text())
    smr = load_spec(path).spec.robot.targets["smr"]
    root["robot"]["tool"] = {c: float(getattr(smr, c).value) for c in "xyz"}
    if drop_effects:
        root.pop("effects")
    stream = io.StringIO()
    yaml.dump(root, stream)
    out.write_text(stream.getvalue())
    return load_spec(out)


def _commands(loaded, registration, goals, orientations, seeds=None):
    """armcal compensate: commands (rad) for the reflector at ``goals`` (tracker frame, mm), tool axes as given, seeds
    (rad) if given; with the rows of its CSV and what it says of a learned residual model."""
    lines = ["name,x,y,z,rx,ry,rz" + ("".join(f",q{j}" for j in range(1, 7)) if seeds is not None else "")]
    for i, (p, R) in enumerate(zip(goals, orientations)):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, (np.linalg.inv(registration) @ np.append(p, 1.0))[:3]
        x, y, z, rz, ry, rx = pose_from_matrix(T)
        seed = np.rad2deg(seeds[i]) if seeds is not None else []
        lines.append(",".join([f"t{i}", *(repr(float(v)) for v in (x, y, z, *np.rad2deg([rx, ry, rz]), *seed))]))
    text, unreached, _, learned = compensate(loaded, None, "\n".join(lines) + "\n", "targets")
    assert not unreached, unreached
    rows = list(csv.DictReader(text.splitlines()))
    return np.deg2rad([[float(r[f"q{j}"]) for j in range(1, 7)] for r in rows]), rows, learned


def registration_of(loaded) -> np.ndarray:
    """The tracker's registration (robot base frame -> tracker frame, 4 x 4) a calibrated spec holds."""
    device = loaded.spec.device.robot_base
    return np.array(xyz_zyx(*(getattr(device, c).value for c in ("x", "y", "z", "rz", "ry", "rx"))), dtype=float)


def test_compensated_commands_reach_the_targets_on_the_true_robot(tmp_path):
    info = write_campaign(tmp_path / "campaign", ROBOT, DEVICE, "gear_harmonic", seed=7, sigmas=5.0, joint=2, order=1, visible=True)
    results = run(info["spec"], tmp_path / "out", pdf=False).results
    assert [e.type for e in results.diagnosis.added_effects] == ["gear_harmonic"]
    geometry, hidden = info["geometry"], info["hidden"]
    true_reflector = lambda Q: readings(geometry, DEVICE, Q, [("smr",)] * len(Q), *hidden).reshape(-1, 3)  # noqa: E731

    Q = np.deg2rad(sample_configurations(ROBOT, TARGETS, np.random.default_rng(70)))
    goals = true_reflector(Q)  # where the true robot's reflector can be: the targets, tracker frame
    calibrated = _with_tool_at_smr(tmp_path / "out" / "calibrated.yaml", tmp_path / "calibrated_tool.yaml")
    registration = registration_of(calibrated)
    axes = compile_robot(calibrated.spec.robot.chain()).tool_poses(Q)[:, :3, :3]  # reachable tool axes
    miss = lambda commands: float(np.sqrt(np.mean((true_reflector(commands) - goals) ** 2)))  # noqa: E731  mm per coordinate

    compensated = miss(_commands(calibrated, registration, goals, axes)[0])
    geometry_only = miss(_commands(_with_tool_at_smr(tmp_path / "out" / "calibrated.yaml", tmp_path / "geometry.yaml", drop_effects=True), registration, goals, axes)[0])
    nominal_spec = _with_tool_at_smr(info["spec"], tmp_path / "nominal_tool.yaml")
    with (info["spec"].parent / "calibration.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    measured_Q = np.deg2rad([[float(r[f"q{j}"]) for j in range(1, 7)] for r in rows])
    measured = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    nominal_chain = compile_robot(nominal_spec.spec.robot.chain())
    nominal_registration = kabsch(nominal_chain.tool_poses(measured_Q)[:, :3, 3], measured)
    nominal = miss(_commands(nominal_spec, nominal_registration, goals, axes)[0])

    assert compensated < TRACKER["noise"]  # mm per coordinate: within the noise floor
    assert nominal / compensated > results.improvement_factor.validation  # whose "after" still holds the noise
    assert nominal == pytest.approx(results.residuals.validation.before.rms, rel=0.3)
    assert geometry_only > 2.0 * compensated  # the harmonic, compensated, counts
