"""import-urdf of mimic joints: a group of mimics on the chain becomes one joint of their master's name, type and
limits, and the spec moves as yourdfpy (which moves mimic joints by m q + o) moves the URDF at random values of the
masters, in every convention; fixed side branches leave the chain alone; what armcal cannot hold is one located
message, exit 1. URDFs: small ones written here, and Hilti's Trailblazer from ../shared/data when it is there."""

import numpy as np
import pytest
import urdf_oracle
from conftest import SHARED_DATA, armcal_cli, random_configurations

from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

TRAILBLAZER = SHARED_DATA / "hilti-trailblazer" / "trailblazer.urdf"
CONVENTIONS = ("dh", "mdh", "six_parameter")


def _rpy(roll, pitch, yaw) -> np.ndarray:
    """URDF's origin rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    def rot(i, a):
        c, s = np.cos(a), np.sin(a)
        j, k = [(1, 2), (2, 0), (0, 1)][i]
        R = np.eye(3)
        R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
        return R
    return rot(2, yaw) @ rot(1, pitch) @ rot(0, roll)


def _vector(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _joint(name, kind, parent, child, xyz="0 0 0", rpy="0 0 0", axis="0 0 1", limit='lower="-1" upper="1"', mimic=""):
    limit = f"<limit {limit}/>" if kind in ("revolute", "prismatic") else ""
    mimic = f"<mimic {mimic}/>" if mimic else ""
    return (f'<joint name="{name}" type="{kind}"><origin xyz="{xyz}" rpy="{rpy}"/><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="{axis}"/>{limit}{mimic}</joint>')


def _robot(*joints) -> str:
    """A URDF of ``joints`` (one a line), its links those they name."""
    names = []
    for joint in joints:
        for role in ("parent", "child"):
            name = joint.split(f'<{role} link="')[1].split('"')[0]
            names += [name] if name not in names else []
    return '<robot name="mimics">\n' + "".join(f'<link name="{n}"/>' for n in names) + "\n" + "\n".join(joints) + "\n</robot>\n"


def _slides(m1: float, m2: float, flip: bool) -> str:
    """A revolute joint, then two prismatic mimics of 'lift' (a master on a side branch, its child a leaf) with
    multipliers m1 and m2 (m1 + m2 = 1) and offsets, fixed rotations and translations between them that leave their axes
    parallel (the second axis written in its own frame; ``flip``: the opposite axis, multiplier -m2), a side branch of
    fixed sensors and a moving finger, then a revolute joint and a fixed tool."""
    turn = (0.3, -0.7, 1.1)
    a1 = np.array([0.0, 0.6, 0.8])
    a2 = _rpy(*turn).T @ a1 * (-1 if flip else 1)
    return _robot(
        _joint("pan", "revolute", "base", "arm", xyz="0.1 0 0.4", rpy="0 0.2 0", axis="0 0 1", limit='lower="-2" upper="2"'),
        _joint("lift", "prismatic", "arm", "lift_tip", xyz="0 0 0", axis="0 0 1", limit='lower="0.2" upper="0.9"'),
        _joint("stage_1", "prismatic", "arm", "carriage", xyz="0.05 -0.02 0.1", rpy="0.4 0 -0.3", axis=_vector(a1),
               limit='lower="0" upper="0.5"', mimic=f'joint="lift" multiplier="{m1!r}" offset="0.12"'),
        _joint("carriage_plate", "fixed", "carriage", "plate", xyz="0.03 0.2 -0.07", rpy=_vector(turn)),
        _joint("camera_mount", "fixed", "carriage", "camera"),
        _joint("stage_2", "prismatic", "plate", "slider", xyz="0.01 0.02 0.03", axis=_vector(a2),
               limit='lower="0" upper="0.5"', mimic=f'joint="lift" multiplier="{(-m2 if flip else m2)!r}" offset="-0.31"'),
        _joint("finger", "revolute", "slider", "finger_tip", axis="1 0 0"),
        _joint("wrist", "revolute", "slider", "hand", xyz="0 0.1 0.05", rpy="1.2 0 0", axis="0 1 0", limit='lower="-3" upper="3"'),
        _joint("hand_tool", "fixed", "hand", "tool", xyz="0.02 0 0.15", rpy="0 0 0.5"),
        _joint("hand_sensor", "fixed", "hand", "sensor", xyz="0.3 0 0"),
    )


TURNING = _robot(  # a revolute mimic with an offset, of a continuous master that moves nothing else
    _joint("slide", "prismatic", "base", "carriage", xyz="0.1 0.2 0", axis="0.6 0 0.8", limit='lower="-0.3" upper="0.4"'),
    _joint("spin", "continuous", "base", "spin_tip", axis="0 0 1"),
    _joint("follower", "revolute", "carriage", "wheel", xyz="0 0.05 0.3", rpy="0.1 0.2 0.3", axis="0 0.8 -0.6",
           mimic='joint="spin" offset="0.4"'),
    _joint("wheel_tool", "fixed", "wheel", "tool", xyz="0.2 0 0"),
)

CASES = {  # name: (URDF text, --base, --tip, the imported joints' names, the links they move)
    "slides": (_slides(0.3, 0.7, False), "base", "tool", ["pan", "lift", "wrist"], ["arm", "slider", "hand"]),
    "slides-negative": (_slides(1.5, -0.5, False), "base", "tool", ["pan", "lift", "wrist"], ["arm", "slider", "hand"]),
    "slides-flipped": (_slides(0.25, 0.75, True), "base", "tool", ["pan", "lift", "wrist"], ["arm", "slider", "hand"]),
    "turning": (TURNING, "base", "tool", ["slide", "spin"], ["carriage", "wheel"]),
}


def _oracle_values(model, names: list[str], types, Q: np.ndarray) -> np.ndarray:
    """yourdfpy's actuated values (rad, m) for armcal's Q (rad, mm) of the joints ``names``: every other one at 0."""
    values = np.zeros((len(Q), len(model.actuated_joint_names)))
    converted = urdf_oracle.joint_values(Q, types)
    for i, name in enumerate(names):
        values[:, model.actuated_joint_names.index(name)] = converted[:, i]
    return values


def _check(tmp_path, urdf, base, tip, names, convention, count, links=()) -> tuple[float, float]:
    """Import in ``convention``; the names, types and limits of the masters; the largest (position, rotation)
    differences from yourdfpy's at ``count`` random configurations: of the tool, and of ``links`` in the URDF that
    `armcal export --format urdf` writes of the spec (where the source has them, so meshes attach)."""
    out = tmp_path / f"{convention}.yaml"
    done = armcal_cli("import-urdf", urdf, "--base", base, "--tip", tip, "--out", out, "--convention", convention)
    assert done.returncode == 0, done.stderr
    assert armcal_cli("validate", out).returncode == 0
    robot = compile_robot(load_spec(out).spec.robot.chain())
    model = urdf_oracle.load(urdf)
    assert list(robot.joint_names) == names
    for name, kind, (low, high) in zip(names, robot.joint_types, robot.limits):
        joint = model.joint_map[name]
        assert kind == ("prismatic" if joint.type == "prismatic" else "revolute")
        expected = (-2 * np.pi, 2 * np.pi) if joint.type == "continuous" else np.array([joint.limit.lower, joint.limit.upper]) * (1000.0 if kind == "prismatic" else 1.0)
        np.testing.assert_allclose([low, high], expected, rtol=1e-11)
    Q = random_configurations(robot, count, seed=29)
    found = urdf_oracle.poses(model, _oracle_values(model, names, robot.joint_types, Q), [tip, *links], base)
    differences = [urdf_oracle.differences(robot.tool_poses(Q), found[tip])]
    if links:
        assert armcal_cli("export", out, "--format", "urdf", "--out", tmp_path / "exported.urdf").returncode == 0
        moved = urdf_oracle.poses(urdf_oracle.load(tmp_path / "exported.urdf"), urdf_oracle.joint_values(Q, robot.joint_types), list(links), base)
        differences += [urdf_oracle.differences(moved[link], found[link]) for link in links]
    return max(d[0] for d in differences), max(d[1] for d in differences)


@pytest.mark.parametrize("convention", CONVENTIONS)
@pytest.mark.parametrize("case", CASES)
def test_mimic_joints_move_as_yourdfpy_moves_them(tmp_path, case, convention):
    """Two prismatic mimics of an off-chain master (multipliers 0.3 and 0.7, 1.5 and -0.5, or 0.25 and -0.75 along
    the opposite axis; offsets; rpy between them) and a revolute mimic with offset 0.4 rad of a continuous master:
    the tool, and each moved link of the exported URDF, 1e-6 mm and 1e-9 at 500 random configurations, in dh, mdh
    and six_parameter."""
    text, base, tip, names, links = CASES[case]
    urdf = tmp_path / "mimics.urdf"
    urdf.write_text(text)
    position, rotation = _check(tmp_path, urdf, base, tip, names, convention, 500, links)
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)


@pytest.mark.skipif(not TRAILBLAZER.exists(), reason="needs ../shared/data/hilti-trailblazer")
@pytest.mark.parametrize("convention", CONVENTIONS)
def test_the_trailblazer_column_is_one_prismatic_joint(tmp_path, convention):
    """Hilti's Trailblazer, base_link to the prism: column_middle_joint and column_top_joint (0.5 q - 0.706 and
    0.5 q - 0.736 m) become column_prismatic_joint (1.48 .. 3.972 m), before dsr_joint1..6, the names of the data
    files; the inertia links, sensors and drill tip on side branches leave the chain alone."""
    names = ["column_prismatic_joint", *(f"dsr_joint{i}" for i in range(1, 7))]
    position, rotation = _check(tmp_path, TRAILBLAZER, "base_link", "prism", names, convention, 300)
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)
    done = armcal_cli("import-urdf", TRAILBLAZER, "--base", "base_link", "--tip", "prism", "--out", tmp_path / "default.yaml")
    assert done.stdout.splitlines()[0].endswith("mimic joints column_middle_joint, column_top_joint replaced by column_prismatic_joint"), done.stdout


def _chain(*joints) -> str:
    """A URDF: ``joints`` on a chain base -> l1 -> l2 ..., each (name, type, extra XML), then a fixed tool; masters
    hang off the base."""
    body, parent = [], "base"
    for i, (name, kind, extra) in enumerate(joints, start=1):
        body.append(f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="l{i}"/>{extra}</joint>')
        parent = f"l{i}"
    masters = ('<joint name="m" type="revolute"><parent link="base"/><child link="m_tip"/><limit lower="-1" upper="1"/></joint>\n'
               '<joint name="p" type="prismatic"><parent link="base"/><child link="p_tip"/><limit lower="0" upper="1"/></joint>\n'
               f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="tool"/></joint>\n')
    links = "".join(f'<link name="{n}"/>' for n in ["base", "m_tip", "p_tip", "tool", *(f"l{i}" for i in range(1, len(joints) + 1))])
    return f'<robot name="r">\n{links}\n' + "\n".join(body) + "\n" + masters + "</robot>\n"


LIMIT = '<limit lower="-1" upper="1"/>'
BAD = {  # name: (URDF text, the message after "FILE:LINE: ")
    "two-revolute": (_chain(("a", "revolute", LIMIT + '<mimic joint="m"/>'), ("f", "fixed", ""), ("b", "revolute", LIMIT + '<mimic joint="m"/>')),
                     "5: joint 'b' mimics 'm' as 'a' (line 3) does: armcal imports one revolute mimic joint per master"),
    "revolute-multiplier": (_chain(("a", "revolute", LIMIT + '<mimic joint="m" multiplier="2"/>')),
                            "3: joint 'a' mimics 'm' with multiplier 2: armcal imports a revolute mimic joint that turns as its master does (multiplier 1)"),
    "gear": (_chain(("a", "prismatic", LIMIT + '<axis xyz="0 0 1"/><mimic joint="p" multiplier="0.5"/>'),
                    ("b", "prismatic", LIMIT + '<axis xyz="0 0 1"/><mimic joint="p" multiplier="0.6"/>')),
             "3: joints 'a', 'b' mimicking 'p' with multipliers 0.5, 0.6 move the chain 1.1 mm per mm of 'p', and armcal's joints move "
             "as their reading does (1 mm per mm): not imported"),
    "master-on-chain": (_chain(("a", "revolute", LIMIT), ("b", "revolute", LIMIT + '<mimic joint="a"/>')),
                        "4: joint 'b' mimics 'a', which is on the chain too (line 3): armcal's joints move each by a value of its own "
                        "(two joints moved by one value are not imported)"),
    "two-groups": (_chain(("a", "prismatic", LIMIT + '<mimic joint="p" multiplier="0.5"/>'), ("r", "revolute", LIMIT),
                          ("b", "prismatic", LIMIT + '<mimic joint="p" multiplier="0.5"/>')),
                   "5: joint 'b' mimics 'p' as 'a' (line 3) does, with a moving joint between them: armcal's joints move each by a value "
                   "of its own (two joints moved by one value are not imported)"),
    "mimic-of-mimic": (_chain(("a", "revolute", LIMIT + '<mimic joint="m"/>'), ("b", "revolute", LIMIT + '<mimic joint="a"/>')),
                       "4: joint 'b' mimics 'a', itself a mimic joint (line 3): armcal imports mimic joints of a joint that moves on its own"),
    "other-kind": (_chain(("a", "prismatic", LIMIT + '<mimic joint="m"/>')),
                   "3: joint 'a' (prismatic) mimics 'm' (revolute, line 4): armcal imports mimic joints of a joint of their kind "
                   "(revolute or continuous, or prismatic)"),
    "no-master": (_chain(("a", "revolute", LIMIT + '<mimic joint="ghost"/>')), "3: joint 'a' mimics 'ghost', which is no joint of the file"),
    "long-name": (_chain(("a", "revolute", LIMIT + f'<mimic joint="{"g" * 300}"/>')),
                  "3: joint 'a' mimics 'a name of 300 characters (not shown)', which is no joint of the file"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_mimic_armcal_cannot_hold_is_one_located_message(tmp_path, case):
    text, message = BAD[case]
    urdf, out = tmp_path / "bad.urdf", tmp_path / "spec.yaml"
    urdf.write_text(text)
    done = armcal_cli("import-urdf", urdf, "--base", "base", "--tip", "tool", "--out", out)
    assert done.returncode == 1 and not out.exists() and "Traceback" not in done.stderr
    assert done.stderr == f"error: {urdf}:{message}\n"
