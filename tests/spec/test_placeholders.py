"""`armcal validate` names the stand-ins `armcal import-urdf` and `armcal new` write (spec `placeholders`), each at its
line, as a warning (exit 0); a value the user gave is silent, and so is a spec that has none. The oracle is the written
file itself: which top-level sections and robot fields it has, and on which line each one stands."""

import re

import pytest
from conftest import ROOT, SPECS, armcal_cli

URDF = ROOT / "tests" / "data" / "urdf" / "ros_industrial.urdf"
WARNING = re.compile(r"^warning: (?P<file>.+):(?P<line>\d+):(?P<column>\d+): (?P<field>[\w.]+): (?P<message>.*)$")


def _placeholder_warnings(spec) -> list[tuple[str, int, str]]:
    """(field, line, message) of each placeholder warning `armcal validate SPEC` prints; it must exit 0."""
    done = armcal_cli("validate", spec)
    assert done.returncode == 0, done.stderr
    found = [WARNING.match(line) for line in done.stderr.splitlines()]
    return [(m["field"], int(m["line"]), m["message"]) for m in found if m and "the stand-in armcal wrote" in m["message"]]


def _line_of(text: str, pattern: str) -> int:
    """1-based line of the only line matching ``pattern``."""
    lines = [i for i, line in enumerate(text.splitlines(), start=1) if re.search(pattern, line)]
    assert len(lines) == 1, (pattern, lines)
    return lines[0]


@pytest.fixture()
def imported(tmp_path):
    spec = tmp_path / "imported.yaml"
    done = armcal_cli("import-urdf", URDF, "--base", "base_link", "--tip", "tool0", "--out", spec)
    assert done.returncode == 0, done.stderr
    return spec


def test_validate_lists_what_import_urdf_left_to_edit(imported):
    text = imported.read_text()
    warnings = _placeholder_warnings(imported)
    assert [(field, line) for field, line, _ in warnings] == [
        ("robot.serial", _line_of(text, r"^  serial: ")), ("robot.targets", _line_of(text, r"^    tool_point: ")),
        ("device", _line_of(text, r"^  type: tracker")), ("procedure", _line_of(text, r"^  type: poses"))]
    assert warnings[0][2].startswith('the stand-in armcal wrote ("EDIT-ME"), unchanged: give the robot\'s serial number')


@pytest.mark.parametrize("device", ["tracker", "ballbar", "sonic_digitizer"])
def test_validate_lists_what_new_left_to_edit(tmp_path, device):
    spec = tmp_path / "cell.yaml"
    assert armcal_cli("new", "--robot", "ur5e", "--device", device, "--out", spec).returncode == 0
    text = spec.read_text()
    sections = [name for name in ("device", "procedure", "validation") if re.search(rf"^{name}:", text, re.M)]
    warnings = _placeholder_warnings(spec)
    assert [field for field, _, _ in warnings] == ["robot.serial", "robot.targets", *sections]
    assert warnings[0][1] == _line_of(text, r"^  serial: SERIAL-NUMBER")
    assert [_section_of(text, line) for _, line, _ in warnings[2:]] == sections


def _section_of(text: str, line: int) -> str:
    """The top-level key whose block holds ``line`` (1-based)."""
    above = [row for row in text.splitlines()[:line] if re.match(r"^\w+:", row)]
    return above[-1].split(":")[0]


def test_a_value_given_is_silent_and_a_spec_with_real_values_lists_none(imported):
    text = imported.read_text()
    given = re.sub(r"(tool_point: \{link: 6, x: \{value: )[^,]+", r"\g<1>60", text.replace('"EDIT-ME"', "KR6-4711")
                   .replace("noise: 0.01", "noise: 0.02").replace("count: 100", "count: 120"))
    assert given.count("\n") == text.count("\n") and given != text
    imported.write_text(given)
    assert _placeholder_warnings(imported) == []
    imported.write_text(text.replace('"EDIT-ME"', "KR6-4711"))  # only the serial given: the others stay
    assert [field for field, _, _ in _placeholder_warnings(imported)] == ["robot.targets", "device", "procedure"]
    imported.write_text(re.sub(r"^  (device|procedure): .*\n", "", text, flags=re.M))  # kept as written: lines removed
    assert [field for field, _, _ in _placeholder_warnings(imported)] == ["robot.serial", "robot.targets"]
    for spec in (SPECS / "puma560_dh.yaml", SPECS / "ur10.yaml"):
        assert _placeholder_warnings(spec) == []


def test_a_placeholder_entry_armcal_did_not_write_is_refused(imported):
    text = imported.read_text()
    imported.write_text(re.sub(r"^  device: [0-9a-f]{16}", "  device: edited", re.sub(r"^  robot\.serial:", "  robot.seriall:", text, flags=re.M), flags=re.M))
    done = armcal_cli("validate", imported)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "placeholders.robot.seriall: Expected 'robot.serial', 'robot.targets', 'device', 'procedure' or 'validation', got 'robot.seriall'." in done.stderr
    assert "placeholders.device: A placeholder's fingerprint is the 16 hex digits armcal wrote; to keep the value as it is, remove the line." in done.stderr
