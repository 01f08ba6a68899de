"""A target on the axis of the joint it rides on is a warning of `armcal validate` (exit 0). The axes come from Stone's
(2.9) by hand, not from armcal: in the PUMA's DH frame 2, A_2 = Rot(z, q2) Trans(0, 0, d2) Trans(a2, 0, 0) Rot(x, 0), so
joint 2's axis (z of frame 1) is the line x = -a2, y = 0; in frame 6 (a6 = 0, alpha6 = 0) joint 6's axis is the z axis."""

import pytest
from conftest import SPECS, armcal_cli

from armcal.devices.registry import INSTRUMENTS
from armcal.kinematics.axis_targets import targets_on_axes
from armcal.commands.new import new_spec_text
from armcal.robot_library import library_robot, names
from armcal.spec import load_spec

A2 = 43.18  # cm, Table 6-2
SPARKERS = "  targets:\n    sparker1:"


def on_axes(path) -> list[tuple[str, int, float]]:
    """``targets_on_axes`` of the spec at ``path``."""
    spec = load_spec(path).spec
    return targets_on_axes(spec.robot.chain(), spec.device.sees_orientation())


def _puma_with(tmp_path, target: str):
    """specs/puma560_dh.yaml (cm) with one more target, ``name: {...}``."""
    text = (SPECS / "puma560_dh.yaml").read_text()
    assert SPARKERS in text
    path = tmp_path / "spec.yaml"
    path.write_text(text.replace(SPARKERS, f"  targets:\n    {target}\n    sparker1:"))
    return path


@pytest.mark.parametrize("target, expected", [
    ("probe: {link: 6, x: 0, y: 0, z: 10}", [("probe", 6)]),
    (f"probe: {{link: 2, x: {-A2}, y: 0, z: 5}}", [("probe", 2)]),
    (f"probe: {{link: 2, x: {-A2}, y: 0.05, z: 5}}", [("probe", 2)]),  # 0.5 mm off: within the 1 mm tolerance
    (f"probe: {{link: 2, x: {-A2}, y: 0.2, z: 5}}", []),  # 2 mm off
    ("probe: {link: 6, x: 3, y: 0, z: 10}", []),
])
def test_a_target_on_its_joints_axis_is_named(tmp_path, target, expected):
    path = _puma_with(tmp_path, target)
    assert [(name, joint) for name, joint, _ in on_axes(path)] == expected
    done = armcal_cli("validate", path)
    assert done.returncode == 0, done.stderr
    warned = [line for line in done.stderr.splitlines() if "axis" in line]
    line = path.read_text().splitlines().index(f"    {target}") + 1
    column = len("    probe: {")  # the target's value
    assert warned == [f"warning: {path}:{line}:{column}: robot.targets.probe: {distance} mm from joint {joint}'s axis: the point does not move "
                      f"when joint {joint} turns, so its readings say nothing of that joint; place it off the axis (docs/devices/tracker.md)"
                      for (_, joint), distance in zip(expected, ["0.0" if "0.05" not in target else "0.5"])]


def test_a_frame_whose_orientation_is_read_sees_the_joint_turn(tmp_path):
    """specs/ur10.yaml's T-Mac lies on joint 6's axis (x = y = 0, a6 = 0, alpha6 = 0) and the tracker reads its orientation."""
    text = (SPECS / "ur10.yaml").read_text()
    assert "tmac: {link: 6, x: 0.0, y: 0.0," in text and "  orientation: true\n" in text and "  orientation_noise: 0.002\n" in text
    assert on_axes(SPECS / "ur10.yaml") == []
    (tmp_path / "positions.yaml").write_text(text.replace("  orientation: true\n", "").replace("  orientation_noise: 0.002\n", ""))
    assert [(name, joint) for name, joint, _ in on_axes(tmp_path / "positions.yaml")] == [("tmac", 6)]


def test_no_target_armcal_new_writes_sits_on_an_axis(tmp_path):
    """Every library robot with every device: the targets `armcal new` writes (a flange point 50 mm off the last axis,
    a sparker per link, Goswami's spheres) lie off the axis of the joint that carries them."""
    for name in names():
        for device in INSTRUMENTS:
            path = tmp_path / f"{name}-{device}.yaml"
            path.write_text(new_spec_text(library_robot(name), device, path.stem))
            assert on_axes(path) == [], (name, device)
