"""The command line follows the conventions of Click tools (issue 20, item 4): --version, -h,
plain metavars, several specs for validate, plain messages for a wrong input."""

import math
import re
import tomllib

import pytest
from conftest import ROOT, SPECS, armcal_cli

from armcal.spec import load_spec

# the commands README.md lists (and `version`): the help must offer each of them
COMMANDS = ["validate", "schema", "fk", "simulate", "run", "report", "montecarlo", "batch", "import-ipa", "new", "export", "compensate", "import-urdf", "compare", "plan", "version"]
TYPE_PLACEHOLDER = re.compile(r"<(bool|path|str|int|float|list|text)\b|\{\w+\}")


def test_version_option_prints_the_project_version():
    expected = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    result = armcal_cli("--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == expected


def test_the_top_level_help_lists_every_command():
    listed = armcal_cli("-h").stdout.split("Commands:", 1)[1]
    assert [line.split()[0] for line in listed.strip().splitlines() if not line.startswith("      ")] == COMMANDS


@pytest.mark.parametrize("command", [[], *([c] for c in COMMANDS)], ids=lambda c: " ".join(c) or "armcal")
def test_help_short_and_long_with_plain_metavars(command):
    short, long = armcal_cli(*command, "-h"), armcal_cli(*command, "--help")
    assert short.returncode == long.returncode == 0, short.stderr + long.stderr
    assert short.stdout == long.stdout
    assert short.stdout.startswith(f"Usage: armcal {' '.join(command)}".rstrip() + " ")
    assert not TYPE_PLACEHOLDER.search(short.stdout), TYPE_PLACEHOLDER.search(short.stdout).group(0)


def test_usage_names_arguments_as_click_does():
    assert armcal_cli("run", "-h").stdout.splitlines()[0] == "Usage: armcal run [OPTIONS] SPEC"
    assert armcal_cli("batch", "-h").stdout.splitlines()[0] == "Usage: armcal batch [OPTIONS] SPEC..."
    assert "--out DIR" in armcal_cli("run", "-h").stdout


def test_validate_takes_several_specs_and_fails_if_any_does(tmp_path):
    broken = tmp_path / "broken.yaml"
    broken.write_text("armcal: 1\nrobot: {name: x}\n")
    missing = tmp_path / "missing.yaml"
    good = SPECS / "puma560_dh.yaml"
    result = armcal_cli("validate", good, broken, missing, SPECS / "ur10.yaml")
    assert result.returncode == 1
    assert f"{good}: valid" in result.stdout and f"{SPECS / 'ur10.yaml'}: valid" in result.stdout
    assert f"{broken}:1:1: device: This field is required." in result.stderr
    assert f"{missing}: cannot read the spec file: there is no such file" in result.stderr
    assert "Traceback" not in result.stderr
    assert armcal_cli("validate", good, SPECS / "ur10.yaml").returncode == 0


def test_report_given_a_spec_says_what_it_expected():
    spec = SPECS / "puma560_dh.yaml"
    result = armcal_cli("report", spec)
    assert result.returncode == 1
    assert result.stderr == f"error: {spec}: expected the results.json that armcal run writes (or its output folder), but this file is not JSON\n"


def _spec_with(tmp_path, old: str, new: str):
    text = (SPECS / "puma560_dh.yaml").read_text()
    assert old in text
    path = tmp_path / "spec.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_an_angle_message_has_the_right_article(tmp_path):
    path = _spec_with(tmp_path, "alpha: -90", "alpha: abc")
    result = armcal_cli("validate", path)
    assert result.returncode == 1
    assert "Expected an angle such as '12.5' or '12.5 deg', got 'abc'." in result.stderr


@pytest.mark.parametrize("written", ["-90°", "-90 °"])
def test_the_degree_sign_is_read_as_degrees(tmp_path, written):
    robot = load_spec(_spec_with(tmp_path, "alpha: -90", f'alpha: "{written}"')).spec.robot
    assert robot.joints[0].alpha.value == pytest.approx(-math.pi / 2, abs=1e-15)


def test_the_degree_sign_is_not_a_length_unit(tmp_path):
    result = armcal_cli("validate", _spec_with(tmp_path, "a: 0, alpha: -90", 'a: "3°", alpha: -90'))
    assert result.returncode == 1
    assert "'°' is not a length unit" in result.stderr
