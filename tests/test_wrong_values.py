"""Values written are the values fitted: YAML anchors shared by two parameters, the campaign's description,
a data file that is not there."""


import pytest

from conftest import EXAMPLE_DATA, ROOT, armcal_cli, copy_example

from armcal.commands.run import run
from armcal.results.schema import Results
from armcal.spec import load_spec

EXAMPLE = ROOT / "examples" / "goswami_ballbar"


def _copy(tmp_path, example="goswami_ballbar"):
    return copy_example(example, tmp_path, (*EXAMPLE_DATA, "truth.json")) / "spec.yaml"


def test_two_parameters_sharing_a_yaml_anchor_get_their_own_values(tmp_path):
    spec = _copy(tmp_path)
    text = spec.read_text()
    text = text.replace("- {x: 43.18, y: 0, z:", "- {x: 43.18, y: &zero {value: 0, vary: true}, z:")
    text = text.replace("- {x: 0, y: 0, z: {value: 0, vary: false}, alpha: {value: 0, vary: false}, beta: 0, gamma: -90}",
                        "- {x: 0, y: *zero, z: {value: 0, vary: false}, alpha: {value: 0, vary: false}, beta: 0, gamma: -90}")
    spec.write_text(text)
    results = run(spec, tmp_path / "out", pdf=False).results
    values = {p.name: p.value for p in results.parameters}
    assert values["L3.y"] != values["L5.y"]  # the fit moved them apart
    calibrated = load_spec(tmp_path / "out" / "calibrated.yaml").spec.robot.links
    assert calibrated[2].y.value == pytest.approx(values["L3.y"] * 10, rel=1e-12)  # cm -> mm
    assert calibrated[4].y.value == pytest.approx(values["L5.y"] * 10, rel=1e-12)


def test_validate_says_a_data_file_is_not_there(tmp_path):
    spec = _copy(tmp_path)
    (tmp_path / "validation.csv").unlink()
    result = armcal_cli("validate", spec)
    assert result.returncode == 0 and "valid" in result.stdout
    line = next(i for i, text in enumerate(spec.read_text().splitlines(), 1) if "validation: validation.csv" in text)
    assert f"warning: {spec}:{line}:" in result.stderr and "data.validation: validation.csv: no such file" in result.stderr
    assert "calibration.csv" not in result.stderr


def test_the_certificate_describes_the_data_not_the_planning_procedure(tmp_path):
    """Measured data are described by themselves; simulated ones say they were simulated, and from what."""
    spec = _copy(tmp_path, "hidden_harmonic")
    simulated = run(spec, tmp_path / "simulated", pdf=False).results.campaign
    assert simulated.procedure.startswith("300 samples at 300 poses from calibration.csv, simulated by armcal")
    (tmp_path / "truth.json").unlink()  # now they are measured data as far as armcal can tell
    measured = run(spec, tmp_path / "measured", pdf=False).results.campaign
    assert measured.procedure == "300 samples at 300 poses from calibration.csv"
    assert measured.validation_procedure == "150 samples at 150 poses from validation.csv"


def _golden():
    import json

    return json.loads((ROOT / "tests" / "data" / "golden" / "results.json").read_text())


def test_an_angle_difference_is_the_shorter_way_round():
    from armcal.report.context import certificate_context

    results = _golden()
    row = next(p for p in results["parameters"] if p["unit"] == "deg")
    row.update(nominal=180.0, value=-179.99, std=0.001)
    shown = next(r for r in certificate_context(Results.model_validate(results), {})["parameters"] if r["name"] == row["name"])
    assert float(shown["difference"]) == pytest.approx(0.01)


def test_a_prismatic_joint_is_plotted_against_its_position_and_torques_say_their_masses_are_assumed():
    from armcal.evaluate.evidence import _joint_axis
    from armcal.report.context import certificate_context

    spec = load_spec(ROOT / "specs" / "puma560_dh.yaml").spec  # units cm, deg
    assert _joint_axis("prismatic", spec) == "joint position (cm)" and _joint_axis("revolute", spec) == "joint angle (deg)"
    results = _golden()
    results["diagnosis"]["plots"] = ["residual_vs_torque.svg"]
    results["diagnosis"]["evidence"] = {
        "unit": "mm", "joints": [], "torque_masses": "5 kg at each link frame's origin beyond the joint (assumed: the spec declares no masses)",
        "gravity_torque": [], "keys": [], "magnitude": "RMS over each sample's readings",
        "histogram": {"edges": [-1.0, 1.0], "counts": [1], "expected": [1.0], "noise_sigma": 0.5, "mean": 0.0, "std": 0.0},
    }
    [plot] = certificate_context(Results.model_validate(results), {"residual_vs_torque.svg": "<svg/>"})["plots"]
    assert "assumed: the spec declares no masses" in plot["title"]
