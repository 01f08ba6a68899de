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
    ("gantry.urdf", "world", "tcp", ["prismatic", "revolute", "revolute", "prismatic", "revolute"]),
])
def test_the_imported_spec_moves_as_yourdfpy_moves_the_urdf(tmp_path, urdf, base, tip, kinds):
    """ROS-Industrial style (rpy origins, axes -z, y, -x, fixed base_link -> base and flange -> tool0, meshes by
    package://, a side branch) and arbitrary unit axes with prismatic joints: tip in base at 1,000 random
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
