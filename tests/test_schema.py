"""`armcal schema` describes every shipped spec, and rejects what the loader rejects."""

import json
import subprocess
import sys

import jsonschema
import pytest
from conftest import ROOT, shipped_specs
from ruamel.yaml import YAML


@pytest.fixture(scope="module")
def schema() -> dict:
    result = subprocess.run([sys.executable, "-m", "armcal", "schema"], capture_output=True, text=True, cwd=ROOT)
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
