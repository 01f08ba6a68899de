"""armcal export: the URDF's forward kinematics, computed here from the XML alone (numpy, the URDF convention:
child = parent * origin(xyz, rpy = Rz(yaw) Ry(pitch) Rx(roll)) * motion about the axis), equal armcal's chain to
1e-6 mm; the DH table reads back the spec's values; the JSON carries results.json's uncertainties."""

import csv
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import urdf_oracle
from conftest import SPECS, armcal_cli, copy_example, random_configurations

from armcal.export import export
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.transforms import pose_from_matrix
from armcal.commands.run import run
from armcal.spec import load_spec

CALIBRATED_UR10 = [  # a UR10 with calibration-sized deviations, Hayati's beta, a base, a tool and a point target
    ("    - {name: shoulder_lift, limits: [-360, 360], theta: 0, d: 0, a: -612.0, alpha: 0}",
     "    - {name: shoulder_lift, limits: [-360, 360], theta: 0.02, d: 0, a: -612.4, alpha: 0.006, beta: 0.001}"),
    ("    - {name: wrist_1, limits: [-360, 360], theta: 0, d: 163.941, a: 0, alpha: 90}",
     "    - {name: wrist_1, limits: [-360, 360], theta: -0.03, d: 163.6, a: 0.03, alpha: 89.99}"),
    ("  base: {rz: {value: 180, vary: false}}", "  base: {x: 12.5, y: -3.0, z: 4.0, rz: 179.9, ry: 0.3, rx: -0.2}\n  tool: {z: 55.0, rx: 10.0}"),
    ("  targets:\n", "  targets:\n    nest: {link: 3, x: 40.0, y: -25.0, z: 10.0}\n"),
]

HAYATI_PUMA = [  # the PUMA's parallel axes 2 and 3 in Hayati's model, with a tilt beta
    ("  convention: dh", "  convention: mdh"),
    ("    - {name: j2, limits: [-225, 45], theta: 0, d: 14.909, a: 43.18, alpha: 0}",
     "    - {name: j2, limits: [-225, 45], theta: 0.1, d: 0, a: 43.18, alpha: 0.05, beta: 0.4}"),
    ("    - {name: j3, limits: [-45, 225], theta: 0, d: 0, a: -2.032, alpha: 90}",
     "    - {name: j3, limits: [-45, 225], theta: 0, d: 14.909, a: -2.032, alpha: 90}"),
]
URDF_CASES = [("ur10.yaml", CALIBRATED_UR10), ("puma560_dh.yaml", ()), ("goswami_puma560.yaml", ()), ("puma560_dh.yaml", HAYATI_PUMA)]
URDF_IDS = ["ur10-dh-beta", "puma560-dh", "goswami-six-parameter", "puma560-mdh"]


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _urdf_poses(text: str, q: np.ndarray) -> dict[str, np.ndarray]:
    """Every link's pose (mm) in the URDF's root link at joint values q (in joint order of the file)."""
    root = ET.fromstring(text)
    joints = root.findall("joint")
    moving = [j for j in joints if j.get("type") != "fixed"]
    value = {j.get("name"): v for j, v in zip(moving, q)}
    poses = {"world": np.eye(4)}
    for joint in joints:  # parents come first in armcal's file
        origin = joint.find("origin")
        xyz = np.array(origin.get("xyz").split(), dtype=float) * 1000.0
        roll, pitch, yaw = map(float, origin.get("rpy").split())
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = _rot("z", yaw) @ _rot("y", pitch) @ _rot("x", roll), xyz
        motion = np.eye(4)
        if joint.get("type") != "fixed":
            axis = np.array(joint.find("axis").get("xyz").split(), dtype=float)
            amount = value[joint.get("name")]
            if joint.get("type") == "prismatic":
                motion[:3, 3] = axis * amount
            else:
                K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
                motion[:3, :3] = np.eye(3) + np.sin(amount) * K + (1 - np.cos(amount)) * K @ K
        poses[joint.find("child").get("link")] = poses[joint.find("parent").get("link")] @ T @ motion
    return poses


def _spec(tmp_path, name, changes=()):
    text = (SPECS / name).read_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("name, changes", [("ur10.yaml", CALIBRATED_UR10), ("puma560_six.yaml", ()), ("puma560_dh.yaml", ())])
def test_the_urdf_moves_as_armcals_chain(tmp_path, name, changes):
    path = _spec(tmp_path, name, changes)
    exported = export(path, "urdf")
    kinematics = compile_robot(load_spec(path).spec.robot.chain())
    rng = np.random.default_rng(4)
    for q in rng.uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (25, kinematics.dof)):
        poses = _urdf_poses(exported.text, q)
        np.testing.assert_allclose(poses["tool0"], kinematics.tool_poses(q[None])[0], atol=1e-6)
        for target in kinematics.targets:
            np.testing.assert_allclose(poses[target], kinematics.target_poses(target, q[None])[0], atol=1e-6)


@pytest.mark.parametrize("name, changes", URDF_CASES, ids=URDF_IDS)
def test_yourdfpy_moves_the_exported_urdf_as_armcals_chain(tmp_path, name, changes):
    """An independent URDF library (yourdfpy, no meshes) reads `armcal export --format urdf`: tool0 and every
    target where armcal puts them at 1,000 random configurations within the limits (1e-6 mm, rotations 1e-9)."""
    path, out = _spec(tmp_path, name, changes), tmp_path / "robot.urdf"
    result = armcal_cli("export", path, "--format", "urdf", "--out", out)
    assert result.returncode == 0, result.stderr
    kinematics = compile_robot(load_spec(path).spec.robot.chain())
    model = urdf_oracle.load(out)
    assert model.actuated_joint_names == list(kinematics.joint_names)
    Q = random_configurations(kinematics, 1000, seed=16)
    expected = {"tool0": kinematics.tool_poses(Q), **{t: kinematics.target_poses(t, Q) for t in kinematics.targets}}
    found = urdf_oracle.poses(model, urdf_oracle.joint_values(Q, kinematics.joint_types), list(expected), "world")
    for link, poses in expected.items():
        position, rotation = urdf_oracle.differences(found[link], poses)
        assert position < 1e-6 and rotation < 1e-9, (link, position, rotation)


def test_an_encoder_scale_the_urdf_cannot_hold_is_named(tmp_path):
    path = _spec(tmp_path, "puma560_six.yaml", [("    - {name: j3, limits: [-45, 225], theta0: 0, k: 1}",
                                                 "    - {name: j3, limits: [-45, 225], theta0: 0, k: 1.001}")])
    assert export(path, "urdf").left_out == ("encoder scale of j3",)


def test_the_dh_table_reads_back_the_spec_and_refuses_an_encoder_scale(tmp_path):
    """A dh spec's own values; a six_parameter chain with k != 1 has no table (its joint does not move by q)."""
    path = _spec(tmp_path, "ur10.yaml", CALIBRATED_UR10)
    rows = [line.split("\t") for line in export(path, "dh-table").text.splitlines() if not line.startswith("#")]
    assert rows[0] == ["joint", "type", "theta (deg)", "d (mm)", "a (mm)", "alpha (deg)", "beta (deg)"]
    lift = dict(zip(rows[0], rows[2]))
    assert lift["joint"] == "shoulder_lift" and float(lift["a (mm)"]) == -612.4 and float(lift["beta (deg)"]) == 0.001
    assert float(dict(zip(rows[0], rows[4]))["alpha (deg)"]) == 89.99
    scaled = _spec(tmp_path, "puma560_six.yaml", [("    - {name: j3, limits: [-45, 225], theta0: 0, k: 1}",
                                                   "    - {name: j3, limits: [-45, 225], theta0: 0, k: 1.001}")])
    result = armcal_cli("export", scaled, "--format", "dh-table", "--out", tmp_path / "t.txt")
    assert result.returncode == 1 and "Traceback" not in result.stderr and not (tmp_path / "t.txt").exists()
    assert result.stderr == (f"error: {scaled}: a DH table's joints move by their readings (theta + q); the encoder scale of "
                             "j3 (k = 1.001) is not 1, so no table holds the chain (export urdf or json)\n")


def test_json_from_a_run_folder_carries_the_results_uncertainties_and_nothing_is_replaced(tmp_path):
    copy_example("hidden_harmonic", tmp_path)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    out = tmp_path / "cal.json"
    first = armcal_cli("export", str(tmp_path / "out"), "--format", "json", "--out", str(out))
    assert first.returncode == 0, first.stderr
    document = json.loads(out.read_text())
    by_name = {p["name"]: p for p in document["parameters"]}
    for parameter in results.parameters:
        if parameter.name in by_name:
            assert by_name[parameter.name]["value"] == pytest.approx(parameter.value, rel=1e-12, abs=1e-12)
            assert by_name[parameter.name]["std"] == parameter.std
    assert [e["type"] for e in document["effects"]] == [e.type for e in results.diagnosis.added_effects]
    again = armcal_cli("export", str(tmp_path / "out"), "--format", "json", "--out", str(out))
    assert again.returncode == 1 and "--force" in again.stderr
    onto_input = armcal_cli("export", str(tmp_path / "out"), "--format", "json", "--out", str(tmp_path / "out" / "calibrated.yaml"), "--force")
    assert onto_input.returncode == 1 and "never replaced" in onto_input.stderr


HARMONIC = "effects:\n  - {type: gear_harmonic, joint: 2, order: 1, sin: 0.05 deg, cos: -0.03 deg}\n  - {type: encoder_scale, joint: 3, scale: 0.0004}\n"


def test_compensated_commands_recover_the_commands_that_made_the_targets(tmp_path):
    """Targets made here: commands q drawn at random, the robot's joints at q + Delta(q) computed in numpy from the
    effects' formulas (harmonic A sin q2 + B cos q2, scale s q3), the calibrated chain's pose there. compensate,
    seeded 2 deg away, returns q to 1e-9 rad; a target 10 m away is named unreachable, not dropped: exit 3 with every
    row written, and with --allow-unreachable exit 0 and the same file."""
    text = (SPECS / "ur10.yaml").read_text().replace("armcal: 1\n", f"armcal: 1\n{HARMONIC}", 1)  # mm and deg
    spec_path = tmp_path / "calibrated.yaml"
    spec_path.write_text(text)
    kinematics = compile_robot(load_spec(spec_path).spec.robot.chain())
    rng = np.random.default_rng(11)
    low, high = kinematics.limits[:, 0], kinematics.limits[:, 1]
    command = rng.uniform(low + 0.3 * (high - low), high - 0.3 * (high - low), (20, kinematics.dof))
    command[:, 2] = rng.choice([-1, 1], 20) * rng.uniform(0.2, 2.5, 20)  # the elbow bent: one branch near the seed
    actual = command.copy()
    actual[:, 1] += np.deg2rad(0.05) * np.sin(command[:, 1]) - np.deg2rad(0.03) * np.cos(command[:, 1])
    actual[:, 2] += 0.0004 * command[:, 2]
    poses = kinematics.tool_poses(actual)
    seeds = np.rad2deg(command) + 2.0
    lines = ["name,x,y,z,rx,ry,rz," + ",".join(f"q{i}" for i in range(1, 7))]
    for i, T in enumerate(poses):
        x, y, z, rz, ry, rx = pose_from_matrix(T)
        lines.append(",".join([f"t{i}", *(repr(float(v)) for v in (x, y, z, *np.rad2deg([rx, ry, rz]), *seeds[i]))]))
    lines.append("far,10000,0,0,0,0,0" + ",0" * 6)
    (tmp_path / "targets.csv").write_text("\n".join(lines) + "\n")
    result = armcal_cli("compensate", str(spec_path), "--targets", str(tmp_path / "targets.csv"), "--out", str(tmp_path / "commands.csv"))
    assert result.returncode == 3, result.stderr  # a target unreachable: exit 3, every row written all the same
    assert "unreachable: far" in result.stdout
    with open(tmp_path / "commands.csv") as stream:
        written = list(csv.DictReader(stream))
    allowed = armcal_cli("compensate", str(spec_path), "--targets", str(tmp_path / "targets.csv"), "--out", str(tmp_path / "commands.csv"),
                         "--force", "--allow-unreachable")
    assert allowed.returncode == 0, allowed.stderr
    with open(tmp_path / "commands.csv") as stream:
        rows = list(csv.DictReader(stream))
    # the same rows, bit for bit: the second process may evaluate with the compiled library where the first used
    # CasADi's virtual machine (ARMCAL_COMPILE=auto builds it once the work pays), which compute the same numbers
    assert rows[:-1] == written[:-1]
    assert [r["name"] for r in rows] == [f"t{i}" for i in range(20)] + ["far"]
    assert rows[-1]["status"].startswith("unreachable")
    got = np.array([[float(r[f"q{j}"]) for j in range(1, 7)] for r in rows[:-1]])
    assert all(r["status"] == "ok" for r in rows[:-1])
    np.testing.assert_allclose(np.deg2rad(got), command, atol=1e-9)


def test_compare_flags_a_change_beyond_its_combined_uncertainty(tmp_path):
    """The same run twice, one parameter moved by 5 combined standard uncertainties and another by 1: only the first
    is significant; another robot's results are refused."""
    copy_example("hidden_harmonic", tmp_path)
    run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False)
    old = json.loads((tmp_path / "out" / "results.json").read_text())
    free = [p for p in old["parameters"] if p["free"] and p["std"]]
    new = json.loads(json.dumps(old))
    moved = {free[0]["name"]: 5.0, free[1]["name"]: 1.0}
    for p in new["parameters"]:
        if p["name"] in moved:
            p["value"] += moved[p["name"]] * np.hypot(p["std"], p["std"])
    (tmp_path / "new.json").write_text(json.dumps(new))
    result = armcal_cli("compare", str(tmp_path / "out"), str(tmp_path / "new.json"))
    assert result.returncode == 0, result.stderr
    flagged = [line.split()[0] for line in result.stdout.splitlines() if line.endswith("significant")]
    assert flagged == [free[0]["name"]] and "1 significant change(s)" in result.stdout
    new["robot"]["serial"] = "another"
    (tmp_path / "other.json").write_text(json.dumps(new))
    refused = armcal_cli("compare", str(tmp_path / "out"), str(tmp_path / "other.json"))
    assert refused.returncode == 1 and "one robot" in refused.stderr
