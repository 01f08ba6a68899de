"""The robot library (specs/robots/) against each robot's URDF, and `armcal new` (issue 16).

Oracle: tests/robot_urdfs.py, the joint origins typed from the ROS-Industrial description
packages (UR, KUKA, ABB, Fanuc, Staubli) and franka_ros, with forward kinematics in plain numpy.
The library's DH tables come from the makers' dimensions; they must put the flange (ROS tool0)
where the URDF does, position and orientation, at the all-zero configuration, the maker's home
and one more configuration. Joint positions are passed to both unchanged: the library's joint
zeros and turning senses are the URDFs' (Fanuc's joint 3 is the relative angle in both).
"""


import numpy as np
import pytest
from conftest import armcal_cli
from robot_urdfs import CHAINS, urdf_flange_pose

from armcal.kinematics.compiler import compile_robot
from armcal.devices.registry import INSTRUMENTS
from armcal.commands.new import new_spec_text
from armcal.robot_library import library_robot, names
from armcal.spec import load_spec

# UR's calibration files round pi/2 to 9 digits (2e-10 rad over ~1 m: 2e-7 mm); every other
# source states exact dimensions.
TOLERANCE_MM = 1e-6
OTHER = np.radians([20.0, -35.0, 40.0, -60.0, 45.0, -70.0, 30.0])


def test_the_library_has_every_robot_of_the_issue():
    assert names() == sorted(CHAINS)


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_flange_pose_equals_the_urdf(name):
    entry = library_robot(name)
    model = compile_robot(entry.robot.chain())
    chain = CHAINS[name]
    assert model.dof == chain.dof == len(entry.home)
    configurations = np.array([np.zeros(model.dof), np.radians(entry.home), OTHER[: model.dof]])
    ours = model.tool_poses(configurations)
    for q, pose in zip(configurations, ours):
        theirs = urdf_flange_pose(chain, q)
        assert np.abs(pose[:3, 3] - 1000 * theirs[:3, 3]).max() < TOLERANCE_MM, (chain.source, np.degrees(q))
        assert np.abs(pose[:3, :3] - theirs[:3, :3]).max() < 1e-9, (chain.source, np.degrees(q))


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_home_lies_within_the_limits(name):
    entry = library_robot(name)
    limits = np.array([j.limits for j in entry.robot.joints])
    home = np.radians(entry.home)
    assert np.all((limits[:, 0] <= home + 1e-12) & (home <= limits[:, 1] + 1e-12))


@pytest.mark.parametrize("device", list(INSTRUMENTS))
def test_new_writes_a_valid_spec_for_every_robot(device, tmp_path):
    for name in names():
        path = tmp_path / f"{name}-{device}.yaml"
        path.write_text(new_spec_text(library_robot(name), device, path.stem))
        spec = load_spec(path).spec
        assert spec.device.type == device and spec.robot.name == library_robot(name).robot.name
        assert "SERIAL-NUMBER" in path.read_text() and "# home:" in path.read_text()


def test_new_then_simulate_and_run_end_to_end(tmp_path):
    result = armcal_cli("new", "--robot", "UR5e", "--device", "tracker", "--out", tmp_path / "cell.yaml")
    assert result.returncode == 0, result.stderr
    assert armcal_cli("simulate", tmp_path / "cell.yaml", "--out", tmp_path).returncode == 0
    run = armcal_cli("run", tmp_path / "cell.yaml", "--no-pdf")
    assert run.returncode == 0, run.stderr
    assert "calibration RMS" in run.stdout and (tmp_path / "out" / "cell" / "results.json").exists()


def test_new_names_the_robots_for_an_unknown_one(tmp_path):
    result = armcal_cli("new", "--robot", "ur5", "--device", "tracker", "--out", tmp_path / "x.yaml")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr.startswith("error: no robot 'ur5' in the library. Did you mean 'ur5e'? The library has: abb_irb120, ")
    assert not (tmp_path / "x.yaml").exists()


def test_new_writes_beside_the_current_folder_and_never_replaces_without_force(tmp_path):
    command = ["new", "--robot", "kuka_kr16_2", "--device", "ballbar"]
    first = armcal_cli(*command, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    written = tmp_path / "kuka_kr16_2-ballbar.yaml"
    written.write_text("mine\n")
    again = armcal_cli(*command, cwd=tmp_path)
    assert again.returncode == 1 and "kuka_kr16_2-ballbar.yaml exists; use --force to replace it" in again.stderr
    assert written.read_text() == "mine\n"
    assert armcal_cli(*command, "--force", cwd=tmp_path).returncode == 0
    assert written.read_text().startswith("# KUKA KR 16-2 measured by a ballbar")


def test_new_lists_the_robots_and_refuses_an_unknown_device():
    listed = armcal_cli("new", "--list").stdout.splitlines()
    assert [line.split()[0] for line in listed] == names()
    assert "Franka Emika Panda" in listed[names().index("franka_panda")]
    wrong = armcal_cli("new", "--robot", "ur5e", "--device", "laser")
    assert wrong.returncode == 1 and "unknown device 'laser'; choose one of sonic_digitizer, ballbar, theodolite, tracker" in wrong.stderr
