"""A wrong spec gives located, plain messages; all of them at once; never a traceback."""

from pathlib import Path

import pytest
from conftest import SPECS, TESTS, armcal_cli

from armcal.support.errors import SpecError
from armcal.spec import load_spec

DATA = TESTS / "data"


def _problems(path: Path) -> list[tuple[int, int, str, str]]:
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    return [(i.line, i.column, i.field, i.message) for i in caught.value.issues]


def test_field_errors_are_located_and_plain():
    assert _problems(DATA / "broken.yaml") == [
        (4, 30, "robot.units.angle", "Expected 'rad', 'deg', 'arcmin' or 'arcsec', got 'degrees'."),
        (8, 16, "robot.joints[1].limits", "The lower limit must be below the upper limit."),
        (8, 52, "robot.joints[1].a", "Expected a length such as '12.5' or '12.5 cm', got 'abc'."),
        (9, 41, "robot.joints[2].d", "'furlong' is not a length unit; use one of mm, cm, m, um, in."),
        (
            9,
            76,
            "robot.joints[2].lenght",
            "This field is unknown here. Remove it or check its spelling. "
            "Allowed here: a, alpha, beta, d, limits, name, theta, type.",
        ),
        (
            13,
            9,
            "device.type",
            "'laser_pointer' is not a known type; use one of 'sonic_digitizer', 'ballbar', 'theodolite', 'tracker', 'sphere_socket', 'plane_contact'.",
        ),
        (16, 10, "procedure.count", "Must be at least 1, got 0."),
    ]


def test_cross_reference_errors_are_located():
    assert _problems(DATA / "broken_references.yaml") == [
        (8, 14, "robot.joints[1].name", "joint name 'j1' is already used by joint 1"),
        (10, 20, "robot.targets.sphere.link", "link 3 does not exist: this robot has links 0..2"),
        (11, 11, "robot.targets.tool", "target name 'tool' clashes with a joint, link, base or tool name"),
        (16, 21, "device.spheres[1]", "sphere 'ghost' is not a robot target (targets: sphere, tool)"),
        (23, 15, "procedure.pairings[0].pivot", "pivot 'p9' is not in device.pivots"),
        (25, 14, "procedure.extension", "extension rod 'long_rod' is not in device.extension_rods"),
        (27, 34, "effects[0].joint", "joint 5 does not exist: this robot has joints 1..2"),
    ]


def test_unknown_key_suggests_its_sibling(tmp_path):
    text = (SPECS / "puma560_dh.yaml").read_text().replace("alpha: -90}", "alhpa: -90}", 1)
    path = tmp_path / "typo.yaml"
    path.write_text(text)
    problems = _problems(path)
    assert any(p[2] == "robot.joints[0].alhpa" and "Did you mean 'alpha'?" in p[3] for p in problems)
    assert any(p[2] == "robot.joints[0].alpha" and p[3] == "This field is required." for p in problems)


def test_yaml_syntax_error_is_located(tmp_path):
    path = tmp_path / "syntax.yaml"
    path.write_text("robot:\n  name: x\n  joints: [1, 2\n")
    [(line, column, field, message)] = _problems(path)
    assert (line, field) == (4, "") and message.startswith("YAML syntax error:")


def test_alias_bomb_is_refused_quickly(tmp_path):
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    path = tmp_path / "bomb.yaml"
    path.write_text("\n".join(lines) + "\n")
    [(_, _, _, message)] = _problems(path)
    assert "anchors and aliases" in message


def test_python_tags_are_not_constructed(tmp_path):
    path = tmp_path / "tag.yaml"
    path.write_text("robot: !!python/object/apply:os.system ['echo hacked']\n")
    assert (1, 8, "robot", "Expected a mapping of keys to values, got ['echo hacked'].") in _problems(path)


def test_quantities_convert_to_mm_and_rad(tmp_path):
    text = (SPECS / "puma560_dh.yaml").read_text().replace("a: 43.18, alpha: 0}", "a: 431.8 mm, alpha: 0.5 rad}")
    path = tmp_path / "units.yaml"
    path.write_text(text)
    joint = load_spec(path).spec.robot.joints[1]
    assert joint.a.value == pytest.approx(431.8)
    assert joint.alpha.value == pytest.approx(0.5)
    assert joint.d.value == pytest.approx(149.09)  # 14.909 cm
    assert joint.limits[0] == pytest.approx(-225 * 3.141592653589793 / 180)


def test_validate_exits_1_without_traceback():
    result = armcal_cli("validate", str(DATA / "broken.yaml"))
    assert result.returncode == 1
    assert "Traceback" not in result.stderr + result.stdout
    assert "broken.yaml:9:41: robot.joints[2].d:" in result.stderr


def test_validate_exits_0_on_a_valid_spec():
    result = armcal_cli("validate", str(SPECS / "puma560_dh.yaml"))
    assert result.returncode == 0, result.stderr
    assert "valid" in result.stdout and "6 joints" in result.stdout


def test_missing_file_is_a_user_error():
    result = armcal_cli("validate", "no/such/spec.yaml")
    assert result.returncode == 1 and "cannot read the spec" in result.stderr and "Traceback" not in result.stderr


@pytest.mark.parametrize(
    "addition, field, message",
    [
        ("effects:\n  - {type: ballbar_length}\n", "effects[0].type", "ballbar_length needs a ballbar device, not theodolite"),
        ("effects:\n  - {type: sensor_scale}\n", "effects[0].type", "sensor_scale needs a sonic_digitizer or tracker device, not theodolite"),
        (
            "effects:\n  - {type: thermal_drift}\n  - {type: thermal_drift, source: time}\n",
            "effects[1]",
            "this thermal_drift effect is already declared as entry 1",
        ),
        ("effects:\n  - {type: thermal_drift, coefficient: 'nan'}\n", "effects[0].coefficient", "Expected a finite number, got nan."),  # quoted
    ],
)
def test_effects_must_fit_the_device_and_be_declared_once(tmp_path, addition, field, message):
    path = tmp_path / "effects.yaml"
    path.write_text((SPECS / "puma560_theodolite.yaml").read_text() + addition)
    assert [(f, m) for _, _, f, m in _problems(path)] == [(field, message)]


def test_a_theodolite_cannot_run_circle_point_sweeps(tmp_path):
    text = (SPECS / "puma560_theodolite.yaml").read_text()
    text = text.replace("procedure:\n  type: poses\n  count: 150\n  seed: 3\n", "procedure:\n  type: circle_point\n  signature: [0, -90, 180, 0, 0, 0]\n  targets: [a, b, c, d, e, f]\n", 1)
    path = tmp_path / "circle.yaml"
    path.write_text(text)
    assert any(f == "procedure.type" and "needs a sonic_digitizer or tracker device, not theodolite" in m for _, _, f, m in _problems(path))


def test_tracker_orientation_needs_its_noise(tmp_path):
    text = (SPECS / "ur10.yaml").read_text().replace("  orientation_noise: 0.002\n", "")
    path = tmp_path / "orientation.yaml"
    path.write_text(text)
    assert [(f, m) for _, _, f, m in _problems(path)] == [("device.orientation_noise", "a tracker that measures orientation needs orientation_noise (its sigma)")]


@pytest.mark.parametrize("insert, expected", [  # lines inserted after the robot's convention (targets: before its own)
    ("  urdf: {links: [{name: a}, {name: b}]}", [("robot.urdf.links", "2 links for 6 joints: name the link each joint moves, in order")]),
    ("  urdf: {base: b, tool: a, links: [{name: a}, {name: b}, {name: c}, {name: d}, {name: e}, {name: f}]}",
     [("robot.urdf", "the URDF link name 'a' is given twice: the world, each link and the tool are links of their own"),
      ("robot.urdf", "the URDF link name 'b' is given twice: the world, each link and the tool are links of their own")]),
    ("  targets:\n    link_2: {link: 2}", [("robot.targets.link_2", "target name 'link_2' clashes with a joint, link, base or tool name")]),
])
def test_urdf_link_names_are_each_one_link(tmp_path, insert, expected):
    """robot.urdf names one link per joint, and the exported URDF's links (world, the links, the tool, each target) once."""
    path = tmp_path / "names.yaml"
    text = (SPECS / "puma560_dh.yaml").read_text()
    anchor = "  targets:\n" if insert.startswith("  targets:") else "  convention: dh\n"
    path.write_text(text.replace(anchor, f"{insert}\n" if anchor == "  targets:\n" else f"{anchor}{insert}\n", 1))
    assert [(field, message) for _, _, field, message in _problems(path)] == expected
