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
    return compile_robot(load_spec(out).spec.robot.chain())


@pytest.mark.parametrize("name, changes", URDF_CASES, ids=URDF_IDS)
def test_importing_armcals_urdf_gives_the_chain_back(tmp_path, name, changes):
    path, urdf = _spec(tmp_path, name, changes), tmp_path / "robot.urdf"
    assert armcal_cli("export", path, "--format", "urdf", "--out", urdf).returncode == 0
    original = compile_robot(load_spec(path).spec.robot.chain())
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
    ("<robot name='r'><link name='a'/><link name='b'/></robot>", "a", "b", " 2 links are no joint's child (a, b); a URDF is one tree from a single root link"),
    (ARM.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><mimic joint="joint_a2"/>'), "base_link", "tool0",
     "39: joint 'joint_a3' mimics 'joint_a2', which is on the chain too (line 32): armcal's joints move each by a value of its own "
     "(two joints moved by one value are not imported)"),
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
    from armcal.support.errors import UserError
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


def _arm(origin='xyz="0.1 0 0.2"', limit='lower="-1" upper="1"', extra="", joints=3, kind="revolute", axis="0 0 1"):
    """A URDF of a chain l0 -> l1 -> ... of ``joints`` joints j0, j1, ..., each with the given origin, limit and axis."""
    links = "".join(f'<link name="l{i}"/>' for i in range(joints + 1))
    body = "".join(f'<joint name="j{i}" type="{kind}"><origin {origin}/><parent link="l{i}"/><child link="l{i + 1}"/>'
                   f'<axis xyz="{axis}"/><limit {limit}/></joint>\n' for i in range(joints))
    return f'<robot name="r">\n{links}\n{body}{extra}</robot>'


OUT_OF_RANGE = [  # (URDF text, --tip, expected message after "FILE:"): numbers beyond armcal's range, graphs no tree
    (_arm(origin='rpy="0 0 1e309"'), "l2", "3: <origin rpy=\"0 0 1e309\">: not 3 finite numbers"),
    (_arm(origin='xyz="0 0 0" rpy="nan 0 0"'), "l2", "3: <origin rpy=\"nan 0 0\">: not 3 finite numbers"),
    (_arm(origin='xyz="0 -2e6 0"'), "l2", "3: <origin xyz=\"0 -2e6 0\">: -2e+06 m lies outside what armcal computes with: magnitudes 1e-30 to 1e+09 mm, or 0"),
    (_arm(limit='lower="-1" upper="1e30"'), "l2", "3: <limit upper=\"1e30\">: 1e+30 rad lies outside what armcal computes with: magnitudes 1e-30 to 1e+09 rad, or 0"),
    (_arm(limit='lower="-3e6" upper="0"', kind="prismatic"), "l2", "3: <limit lower=\"-3e6\">: -3e+06 m lies outside what armcal computes with: magnitudes 1e-30 to 1e+09 mm, or 0"),
    (_arm(axis="1e300 1e300 0"), "l2", "3: <axis xyz=\"1e300 1e300 0\">: 1e+300 lies outside what armcal computes with: magnitudes 1e-30 to 1e+09, or 0"),
    (_arm(extra='<link name="loose"/>'), "l2", " 2 links are no joint's child (l0, loose); a URDF is one tree from a single root link"),
    (_arm(extra='<joint name="s" type="fixed"><parent link="l2"/><child link="l2"/></joint>'), "l2", "6: joint 's' joins link 'l2' to itself; a URDF is a tree"),
    (_arm(extra='<link name="b"/><link name="c"/><joint name="bc" type="fixed"><parent link="b"/><child link="c"/></joint>'
                '<joint name="cb" type="fixed"><parent link="c"/><child link="b"/></joint>'), "l2",
     "6: the joints form a cycle (b -> c -> b: none of them below the root link 'l0'); a URDF is a tree"),
    (_arm().replace('<child link="l3"/>', '<child link="l0"/>').replace('<link name="l3"/>', ""), "l2",
     "5: the joints form a cycle (l0 -> l1 -> l2 -> l0: every link is a joint's child, so none is the root); a URDF is a tree"),
    (_arm(extra='<link name="l1"/>'), "l2", "6: link 'l1' is declared twice (first on line 2)"),
    (_arm().replace('name="j2"', 'name="j0"'), "l2", "5: joint 'j0' is declared twice (first on line 3)"),
    (_arm().replace('<child link="l3"/>', '<child link="ghost"/>'), "l2", "5: joint 'j2': its child link 'ghost' is no <link> of the file"),
]


@pytest.mark.parametrize("text, tip, message", OUT_OF_RANGE, ids=["inf-rpy", "nan-rpy", "2e6-m", "1e30-rad", "prismatic-3e6-m", "axis-1e300",
                                                                  "two-roots", "self-loop", "cycle-beside-root", "rootless-cycle",
                                                                  "link-twice", "joint-twice", "undeclared-link"])
def test_a_number_out_of_range_or_a_graph_that_is_no_tree_is_refused(tmp_path, text, tip, message):
    """Issue 30 class 7: every number import-urdf reads is finite and within 1e9 mm or rad (units.to_internal), and
    the joints are one tree from a single root: anything else is one located message, never a spec."""
    from armcal.support.errors import UserError
    from armcal.importers.urdf import read_urdf

    path = tmp_path / "bad.urdf"
    path.write_text(text)
    with pytest.raises(UserError) as raised:
        read_urdf(path, "l0", tip)
    assert str(raised.value) == f"{path}:{message}"


def test_what_import_urdf_writes_validates_or_nothing_is_written(tmp_path):
    """The written spec is one `armcal validate` loads: dust below 1e-30 m reads as 0 and origins near the largest
    length armcal computes with are written as read; fixed origins that add up beyond it, a chain of more joints
    than a spec file holds and one whose spec would exceed 256 KiB end with exit 1 and no file."""
    from armcal.importers.urdf import MAX_JOINTS

    edge = tmp_path / "edge.urdf"
    edge.write_text(_arm(origin='xyz="9e5 3e-35 -1e-40" rpy="1e-300 0 0"', limit='lower="-1e6" upper="1e6"'))
    out = tmp_path / "edge.yaml"
    done = armcal_cli("import-urdf", edge, "--base", "l0", "--tip", "l3", "--out", out)
    assert done.returncode == 0, done.stderr
    robot = load_spec(out).spec.robot
    chain = compile_robot(robot.chain())
    np.testing.assert_allclose(chain.limits[0], [-1e6, 1e6])
    np.testing.assert_allclose(chain.tool_poses(np.zeros((1, 3)))[0][:3, 3], [2.7e9 / 1000 * 1000, 0, 0], rtol=1e-12)
    assert armcal_cli("validate", out).returncode == 0

    def compact(joints):  # the shortest URDF of a chain: about 110 bytes a joint
        links = "".join(f'<link name="{i}"/>' for i in range(joints + 1))
        body = "".join(f'<joint name="j{i}" type="revolute"><parent link="{i}"/><child link="{i + 1}"/><limit upper="1"/></joint>' for i in range(joints))
        return f'<robot name="r">{links}{body}</robot>'

    cases = {"sum.urdf": (_arm(origin='xyz="6e5 0 0"', kind="fixed").replace('name="j2" type="fixed"', 'name="j2" type="revolute"'), "3",
                          "the chain makes no valid spec: robot.links[0].x: 1800000000 lies outside what armcal computes with"),
             "many.urdf": (compact(MAX_JOINTS + 1), str(MAX_JOINTS + 1), f"{MAX_JOINTS + 1} joints from 'l0' to '{MAX_JOINTS + 1}': a spec file holds at most {MAX_JOINTS}"),
             "large.urdf": (compact(1800), "1800", "the chain makes a spec of ")}
    for name, (text, tip, message) in cases.items():
        path, spec = tmp_path / name, tmp_path / f"{name}.yaml"
        path.write_text(text.replace('"0"', '"l0"') if name != "sum.urdf" else text)
        done = armcal_cli("import-urdf", path, "--base", "l0", "--tip", f"l{tip}" if name == "sum.urdf" else tip, "--out", spec)
        assert done.returncode == 1 and "Traceback" not in done.stderr and not spec.exists(), done.stderr
        assert done.stderr.startswith(f"error: {path}: {message}"), done.stderr


@pytest.mark.parametrize("urdf, base, tip", [("arm", "l0", "l3"), (URDFS / "ros_industrial.urdf", "base_link", "tool0")], ids=["tool-on-axis", "ros-industrial"])
def test_the_stand_in_target_is_off_the_last_joints_axis(tmp_path, urdf, base, tip):
    """Turned by 90 deg on the last joint alone, a point at r from its axis moves by sqrt(2) r. The stand-in target lies
    50 mm farther out than the tool's origin, whose r yourdfpy gives (0 where the tip is the last joint's child link,
    3 mm for the ROS-Industrial arm's tool0); the spec still validates, with no target on its joint's axis."""
    if urdf == "arm":
        urdf = tmp_path / "arm.urdf"
        urdf.write_text(_arm())
    out = tmp_path / "imported.yaml"
    assert armcal_cli("import-urdf", urdf, "--base", base, "--tip", tip, "--out", out).returncode == 0
    robot = load_spec(out).spec.robot
    chain = compile_robot(robot.chain())
    Q = random_configurations(chain, 5, seed=3)
    turned = Q.copy()
    turned[:, -1] += np.pi / 2
    model = urdf_oracle.load(urdf)
    tool = [urdf_oracle.poses(model, urdf_oracle.joint_values(q, chain.joint_types), [tip], base)[tip][:, :3, 3] for q in (Q, turned)]
    target = [chain.target_poses("tool_point", q)[:, :3, 3] for q in (Q, turned)]
    r_tool, r_target = (np.linalg.norm(after - before, axis=1) / np.sqrt(2) for before, after in (tool, target))
    np.testing.assert_allclose(r_target, r_tool + 50.0, atol=1e-6)
    done = armcal_cli("validate", out)
    assert done.returncode == 0 and "axis" not in done.stderr, done.stderr
