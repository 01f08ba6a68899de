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
from robot_urdfs import CHAINS, urdf_flange_pose

from armcal.kinematics.compiler import compile_robot
from armcal.robot_library import library_robot, names

# UR's calibration files round pi/2 to 9 digits (2e-10 rad over ~1 m: 2e-7 mm); every other
# source states exact dimensions.
TOLERANCE_MM = 1e-6
OTHER = np.radians([20.0, -35.0, 40.0, -60.0, 45.0, -70.0, 30.0])


def test_the_library_has_every_robot_of_the_issue():
    assert names() == sorted(CHAINS)


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_flange_pose_equals_the_urdf(name):
    entry = library_robot(name)
    model = compile_robot(entry.robot)
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
