"""armcal import-urdf: the spec it writes moves as the URDF does. The oracles are yourdfpy (an independent URDF
library, tests/urdf_oracle.py) for hand-written URDFs, and armcal's own chain for the URDFs `armcal export`
writes (import of export gives the chain back); bad URDFs end with one located message, exit 1."""

import numpy as np
import pytest
import urdf_oracle
from conftest import ROOT, armcal_cli, random_configurations
from test_export import URDF_CASES, URDF_IDS, _spec

from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

URDFS = ROOT / "tests" / "data" / "urdf"


def _imported(tmp_path, urdf, base, tip):
    """The compiled robot of `armcal import-urdf URDF --base BASE --tip TIP` (the spec validates on loading)."""
    out = tmp_path / "imported.yaml"
    result = armcal_cli("import-urdf", urdf, "--base", base, "--tip", tip, "--out", out)
    assert result.returncode == 0, result.stderr
    return compile_robot(load_spec(out).spec.robot)


@pytest.mark.parametrize("name, changes", URDF_CASES, ids=URDF_IDS)
def test_importing_armcals_urdf_gives_the_chain_back(tmp_path, name, changes):
    path, urdf = _spec(tmp_path, name, changes), tmp_path / "robot.urdf"
    assert armcal_cli("export", path, "--format", "urdf", "--out", urdf).returncode == 0
    original = compile_robot(load_spec(path).spec.robot)
    imported = _imported(tmp_path, urdf, "world", "tool0")
    assert imported.joint_names == original.joint_names and imported.joint_types == original.joint_types
    np.testing.assert_allclose(imported.limits, original.limits, rtol=1e-11)
    Q = random_configurations(original, 1000, seed=17)
    position, rotation = urdf_oracle.differences(imported.tool_poses(Q), original.tool_poses(Q))
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)


@pytest.mark.parametrize("urdf, base, tip, kinds", [
    ("ros_industrial.urdf", "base_link", "tool0", ["revolute"] * 6),
    ("ros_industrial.urdf", "base", "tool0", ["revolute"] * 6),  # up the fixed base_link -> base, then down
    ("gantry.urdf", "world", "tcp", ["prismatic", "revolute", "revolute", "prismatic", "revolute"]),
])
def test_the_imported_spec_moves_as_yourdfpy_moves_the_urdf(tmp_path, urdf, base, tip, kinds):
    """ROS-Industrial style (rpy origins, axes -z, y, -x, fixed base_link -> base and flange -> tool0, meshes by
    package://, a side branch; from base_link, and from the controller's base) and arbitrary unit axes with prismatic joints: tip in base at 1,000 random
    configurations within the imported limits, 1e-6 mm and 1e-9, against yourdfpy."""
    imported = _imported(tmp_path, URDFS / urdf, base, tip)
    model = urdf_oracle.load(URDFS / urdf)
    assert list(imported.joint_types) == kinds and list(imported.joint_names) == model.actuated_joint_names
    for joint, (low, high) in zip(model.actuated_joints, imported.limits):
        expected = (-2 * np.pi, 2 * np.pi) if joint.type == "continuous" else np.array([joint.limit.lower, joint.limit.upper]) * (1000.0 if joint.type == "prismatic" else 1.0)
        np.testing.assert_allclose([low, high], expected, rtol=1e-11)
    Q = random_configurations(imported, 1000, seed=18)
    found = urdf_oracle.poses(model, urdf_oracle.joint_values(Q, imported.joint_types), [tip], base)[tip]
    position, rotation = urdf_oracle.differences(imported.tool_poses(Q), found)
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)


ARM = (URDFS / "ros_industrial.urdf").read_text()
BAD_URDFS = [  # (URDF text, --base, --tip, expected message after "FILE:")
    ("<robot name='r'><link name='a'></robot>", "a", "a", "1:34: not XML: mismatched tag"),
    ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>\n<robot name="&b;"/>',
     "a", "b", "2: the file has a DOCTYPE; a URDF needs none, and armcal reads none (entities are not expanded)"),
    ("<sdf version='1.6'/>", "a", "b", "1: the top element is <sdf>, not a URDF's <robot>"),
    ('<robot name="r" xmlns:xacro="http://ros.org/wiki/xacro">\n  <xacro:include filename="$(find x)/arm.xacro"/>\n</robot>', "a", "b",
     "2: <xacro:include>: this is a xacro file; armcal runs nothing, expand it first (xacro FILE > robot.urdf)"),
    (ARM, "base_link", "ghost", " no link 'ghost'; the links are base_link, link_1, link_2, link_3, link_4, link_5, link_6, flange, tool0, base, camera_link"),
    (ARM, "tool0", "base_link", " no chain from 'tool0' to 'base_link': 'tool0' is neither a link above 'base_link' (none) nor one fixed to such a link"),
    (ARM, "tool0", "camera_link", " no chain from 'tool0' to 'camera_link': 'tool0' is neither a link above 'camera_link' (link_3, link_2, link_1, base_link) nor one fixed to such a link"),
    ("<robot name='r'><link name='a'/><link name='b'/></robot>", "a", "b", " no chain from 'a' to 'b': they are in two trees"),
    (ARM.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><mimic joint="joint_a2"/>'), "base_link", "tool0",
     "39: joint 'joint_a3' mimics another joint; armcal's joints are independent (mimic joints are not imported)"),
    (ARM.replace('name="joint_a4" type="revolute"', 'name="joint_a4" type="floating"'), "base_link", "tool0",
     "46: joint 'joint_a4' is floating; armcal imports revolute, continuous, prismatic and fixed joints"),
    (ARM.replace('name="joint_a4" type="revolute"', 'name="joint_a4" type="planar"'), "base_link", "tool0",
     "46: joint 'joint_a4' is planar; armcal imports revolute, continuous, prismatic and fixed joints"),
    (ARM.replace('<origin xyz="0.420 0 0"', '<origin xyz="${a5_x} 0 0"'), "base_link", "tool0",
     "54: <origin xyz=\"${a5_x} 0 0\">: not 3 numbers (a xacro expression? run xacro first)"),
    (ARM.replace('<axis xyz="-1 0 0"/>\n    <limit lower="-3.2288591161895095" upper="3.2288591161895095" effort="0" velocity="6.283185307179586"/>',
                 '<axis xyz="-1 0 0"/>'), "base_link", "tool0", "46: joint 'joint_a4' (revolute) has no <limit>; URDF requires one"),
    (ARM, "link_6", "tool0", " no revolute, continuous or prismatic joint between 'link_6' and 'tool0'"),
]


@pytest.mark.parametrize("text, base, tip, message", BAD_URDFS, ids=["not-xml", "doctype", "not-urdf", "xacro", "no-link", "upwards",
                                                                    "side-branch", "two-trees", "mimic", "floating", "planar", "expression", "no-limit", "no-joint"])
def test_a_bad_urdf_is_one_located_message(tmp_path, text, base, tip, message):
    from armcal.errors import UserError
    from armcal.importers.urdf import read_urdf

    path = tmp_path / "bad.urdf"
    path.write_text(text)
    with pytest.raises(UserError) as raised:
        read_urdf(path, base, tip)
    assert str(raised.value) == f"{path}:{message}"


def test_the_command_refuses_a_large_file_and_replaces_nothing(tmp_path):
    large = tmp_path / "large.urdf"
    large.write_text("<robot>" + " " * (16 << 20) + "</robot>")
    result = armcal_cli("import-urdf", large, "--base", "a", "--tip", "b", "--out", tmp_path / "spec.yaml")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr == f"error: {large}: cannot read the urdf file: it has 16 MiB, more than the 16 MiB a urdf file may have\n"
    existing = tmp_path / "spec.yaml"
    existing.write_text("mine")
    again = armcal_cli("import-urdf", URDFS / "gantry.urdf", "--base", "world", "--tip", "tcp", "--out", existing)
    assert again.returncode == 1 and "--force" in again.stderr and existing.read_text() == "mine"
