"""armcal export --format ur-calibration: the file Universal Robots' ROS driver reads, checked by building the arm
as ur_description does (UniversalRobots/Universal_Robots_ROS2_Description, urdf/ur_macro.xacro: base_link ->
base_link_inertia Rz(pi); joint i's origin xyz + rpy (R = Rz(yaw) Ry(pitch) Rx(roll)) from the file, axis z;
wrist_3_link -> flange rpy (0, -pi/2, -pi/2) -> tool0 rpy (pi/2, 0, pi/2)) in numpy from the YAML alone."""

import numpy as np
import pytest
from conftest import SPECS, armcal_cli
from ruamel.yaml import YAML

from armcal.export import export
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

SEGMENTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")

# ur_description's config/ur10/default_kinematics.yaml (the UR10's nominal joint origins, m and rad)
UR10_DEFAULT = {
    "shoulder": (0, 0, 0.1273, 0, 0, 0),
    "upper_arm": (0, 0, 0, np.pi / 2, 0, 0),
    "forearm": (-0.612, 0, 0, 0, 0, 0),
    "wrist_1": (-0.5723, 0, 0.163941, 0, 0, 0),
    "wrist_2": (0, -0.1157, 0, np.pi / 2, 0, 0),
    "wrist_3": (0, 0.0922, 0, np.pi / 2, np.pi, np.pi),
}

CALIBRATED = [  # deviations of a calibration's size on every kind of DH parameter, Hayati's beta on a parallel axis
    ("    - {name: shoulder_pan, limits: [-360, 360], theta: 0, d: 127.3, a: 0, alpha: 90}",
     "    - {name: shoulder_pan, limits: [-360, 360], theta: 0.011, d: 127.9, a: 0.21, alpha: 90.02}"),
    ("    - {name: elbow, limits: [-360, 360], theta: 0, d: 0, a: -572.3, alpha: 0}",
     "    - {name: elbow, limits: [-360, 360], theta: -0.04, d: 0, a: -571.8, alpha: 0.01, beta: -0.02}"),
    ("    - {name: wrist_2, limits: [-360, 360], theta: 0, d: 115.7, a: 0, alpha: -90}",
     "    - {name: wrist_2, limits: [-360, 360], theta: 0.05, d: 115.2, a: -0.12, alpha: -89.97}"),
    ("    - {name: wrist_3, limits: [-360, 360], theta: 0, d: 92.2, a: 0, alpha: 0}",
     "    - {name: wrist_3, limits: [-360, 360], theta: 0.3, d: 92.5, a: 0, alpha: 0}"),
]


def _rpy(x, y, z, roll, pitch, yaw) -> np.ndarray:
    def rot(i, j, angle):
        R = np.eye(4)
        c, s = np.cos(angle), np.sin(angle)
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
        return R

    T = rot(0, 1, yaw) @ rot(2, 0, pitch) @ rot(1, 2, roll)
    T[:3, 3] = np.array([x, y, z]) * 1000.0
    return T


def _tool0_in_base_link(kinematics: dict, q: np.ndarray) -> np.ndarray:
    """ur_description's tool0 in base_link (mm) at joint values q (rad)."""
    T = _rpy(0, 0, 0, 0, 0, np.pi)  # base_link -> base_link_inertia
    for name, angle in zip(SEGMENTS, q):
        o = kinematics[name]
        T = T @ _rpy(o["x"], o["y"], o["z"], o["roll"], o["pitch"], o["yaw"]) @ _rpy(0, 0, 0, 0, 0, angle)
    return T @ _rpy(0, 0, 0, 0, -np.pi / 2, -np.pi / 2) @ _rpy(0, 0, 0, np.pi / 2, 0, np.pi / 2)


def _spec(tmp_path, changes):
    text = (SPECS / "ur10.yaml").read_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "ur10.yaml"
    path.write_text(text)
    return path


def test_the_nominal_ur10_gives_ur_descriptions_default_kinematics():
    exported = export(SPECS / "ur10.yaml", "ur-calibration")
    kinematics = YAML(typ="safe").load(exported.text)["kinematics"]
    for name, expected in UR10_DEFAULT.items():
        got = _rpy(*(kinematics[name][k] for k in ("x", "y", "z", "roll", "pitch", "yaw")))
        np.testing.assert_allclose(got, _rpy(*expected), atol=1e-12, err_msg=name)
    assert kinematics["hash"].startswith("armcal_")
    assert exported.left_out == ()


def test_the_driver_builds_armcals_calibrated_arm(tmp_path):
    """The specs/ur10.yaml world is ROS's base_link (its robot.base is the Rz(180) to the DH frame): tool0 from the
    file equals armcal's tool pose to 1e-6 mm at 1,000 random configurations of a calibrated UR10."""
    path = _spec(tmp_path, CALIBRATED)
    exported = export(path, "ur-calibration")
    kinematics = YAML(typ="safe").load(exported.text)["kinematics"]
    chain = compile_robot(load_spec(path).spec.robot.chain())
    Q = np.random.default_rng(16).uniform(-np.pi, np.pi, (1000, 6))
    armcal_tool = chain.tool_poses(Q)
    worst = max(np.max(np.abs(_tool0_in_base_link(kinematics, q) - T)) for q, T in zip(Q, armcal_tool))
    assert worst < 1e-6
    assert exported.left_out == ()


def test_what_the_file_cannot_hold_is_named(tmp_path):
    path = _spec(tmp_path, [*CALIBRATED, ("  base: {rz: {value: 180, vary: false}}",
                                          "  base: {x: 3.0, rz: 179.8}\n  tool: {z: 55.0, rx: 10.0}")])
    exported = export(path, "ur-calibration")
    assert any("robot's mounting (robot.base: x 3" in item for item in exported.left_out)
    assert any("tool's offset from tool0 (x 0, y 0, z 55 mm" in item for item in exported.left_out)
    assert exported.text.count("# Not held by this file") == 1


def test_other_chains_are_refused_with_the_reason(tmp_path):
    result = armcal_cli("export", str(SPECS / "goswami_puma560.yaml"), "--format", "ur-calibration", "--out", str(tmp_path / "k.yaml"))
    assert result.returncode == 1
    assert "six revolute joints of a DH chain; this robot is six_parameter" in result.stderr + result.stdout
    assert not (tmp_path / "k.yaml").exists()


@pytest.mark.parametrize("fmt", ["ur-calibration"])
def test_the_cli_writes_the_file_and_replaces_nothing_without_force(tmp_path, fmt):
    out = tmp_path / "kinematics.yaml"
    first = armcal_cli("export", str(SPECS / "ur10.yaml"), "--format", fmt, "--out", str(out))
    assert first.returncode == 0, first.stderr
    again = armcal_cli("export", str(SPECS / "ur10.yaml"), "--format", fmt, "--out", str(out))
    assert again.returncode == 1 and "--force" in again.stderr + again.stdout


def test_the_terminal_names_what_is_left_out_and_offers_compensation(tmp_path):
    path = _spec(tmp_path, [("  base: {rz: {value: 180, vary: false}}", "  base: {rz: {value: 180, vary: false}}\n  tool: {z: 55.0}")])
    result = armcal_cli("export", path, "--format", "ur-calibration", "--out", tmp_path / "k.yaml")
    assert result.returncode == 0, result.stderr
    assert "not held by ur-calibration (calibrated.yaml keeps them): the tool's offset from tool0 (x 0, y 0, z 55 mm" in result.stdout
    assert f"a program carries them all: armcal compensate {path} --targets TARGETS.csv --out COMMANDS.csv" in result.stdout
