"""`armcal schema` describes every shipped spec, and rejects what the loader rejects."""

import json

import jsonschema
import pytest
from conftest import ROOT, armcal_cli, shipped_specs
from ruamel.yaml import YAML


@pytest.fixture(scope="module")
def schema() -> dict:
    result = armcal_cli("schema")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def _data(path):
    return YAML(typ="safe").load(path.read_text())


@pytest.mark.parametrize("path", shipped_specs(), ids=lambda p: p.name)
def test_schema_validates_shipped_spec(schema, path):
    jsonschema.validate(_data(path), schema)


def test_at_least_one_spec_per_device_and_convention():
    specs = [_data(p) for p in shipped_specs()]
    assert {s["device"]["type"] for s in specs} >= {"sonic_digitizer", "ballbar", "theodolite", "tracker"}
    assert {s["robot"]["convention"] for s in specs} >= {"dh", "s_model", "six_parameter"}


def test_schema_rejects_unknown_keys_and_types(schema):
    spec = _data(ROOT / "specs" / "puma560_dh.yaml")
    spec["robot"]["joints"][0]["lenght"] = 3
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(spec, schema)
    spec = _data(ROOT / "specs" / "puma560_dh.yaml")
    spec["device"]["type"] = "laser_pointer"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(spec, schema)


SHIPPED = ROOT / "schema" / "armcal-spec.schema.json"
EDITOR_LINE = "# yaml-language-server: $schema=../schema/armcal-spec.schema.json\n"

# every robot parameter of every convention (robot.py's docstring, Stone (2.9), (3.2), Goswami (2), (3)),
# and what its description must cite
ROBOT_PARAMETERS = {
    "DHJoint": {"theta": "(2.9)", "d": "(2.9)", "a": "(2.9)", "alpha": "(2.9)", "beta": "Hayati"},
    "MDHJoint": {"theta": "(2.9)", "d": "(2.9)", "a": "(2.9)", "alpha": "(2.9)", "beta": "Hayati"},
    "SModelJoint": {"beta": "(3.2)", "d": "(3.2)", "a": "(3.2)", "alpha": "(3.2)", "gamma": "(3.2)", "b": "(3.2)"},
    "SixParameterJoint": {"theta0": "(2)", "k": "(2)"},
    "SixParameterLink": {"x": "(3)", "y": "(3)", "z": "(3)", "alpha": "(3)", "beta": "(3)", "gamma": "(3)"},
    "Pose": {"x": "x", "y": "y", "z": "z", "rx": "Rot(x, rx)", "ry": "Rot(y, ry)", "rz": "Rot(z, rz)"},
    "Target": {"x": "x", "y": "y", "z": "z", "rx": "Rot(x, rx)"},
}


def test_the_schema_has_an_id(schema):
    assert schema["$id"].startswith("urn:armcal:")
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"


@pytest.mark.parametrize("definition", ROBOT_PARAMETERS)
def test_every_robot_parameter_says_what_it_means(schema, definition):
    properties = schema["$defs"][definition]["properties"]
    for name, cited in ROBOT_PARAMETERS[definition].items():
        description = properties[name].get("description", "")
        assert cited in description, f"{definition}.{name}: {description!r}"
        assert "parameter: a value" not in description and "in the spec unit" not in description, f"{definition}.{name}"


def test_parameters_carry_examples_of_both_forms(schema):
    theta = schema["$defs"]["DHJoint"]["properties"]["theta"]
    examples = theta["examples"]
    assert any(isinstance(e, (int, float)) for e in examples) and any(isinstance(e, dict) for e in examples)
    for example in examples:
        jsonschema.validate(example, theta)


def test_the_shipped_schema_is_armcal_schema():
    result = armcal_cli("schema")
    assert SHIPPED.read_text() == result.stdout, "regenerate: armcal schema > schema/armcal-spec.schema.json"


def test_a_spec_with_the_editor_line_validates(tmp_path):
    """The line docs/spec.md documents is a comment to armcal and names the shipped schema, relative to a spec in specs/."""
    assert EDITOR_LINE.strip() in (ROOT / "docs" / "spec.md").read_text()
    spec = tmp_path / "specs" / "puma560_dh.yaml"
    spec.parent.mkdir()
    spec.write_text(EDITOR_LINE + (ROOT / "specs" / "puma560_dh.yaml").read_text())
    result = armcal_cli("validate", spec)
    assert result.returncode == 0, result.stderr
    named = (ROOT / "specs" / EDITOR_LINE.split("$schema=")[1].strip()).resolve()
    assert named == SHIPPED
    jsonschema.validate(_data(spec), json.loads(named.read_text()))
