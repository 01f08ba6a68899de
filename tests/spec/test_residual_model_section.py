"""The spec's residual_model section (a learned model calibrated.yaml stores, spec/learned.py): every mistake in it,
hand-made or of another robot, is one located plain message and exit 1; compensate says what it cannot carry."""

import json
import subprocess
import sys
from types import SimpleNamespace

import pytest
from conftest import ROOT

import independent_sim as sim
from armcal.commands.run import residual_model_note
from armcal.export.compensation import compensate
from armcal.results.calibrated import calibrated_yaml
from armcal.results.schema import Results
from armcal.spec import load_spec
from armcal.support.errors import SpecError, UserError
from armcal.export.parameters import learned_section

ROW = "[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]"
TARGETS = "name,x,y,z,rx,ry,rz\nt1,600,150,300,0,90,0\n"


def _section(inputs=f"[{ROW}, {ROW}]", targets="[0.01, 0.02]", coordinate="base_z", noise="0.0004", scales="[1, 1, 1, 1, 1, 1]",
             units="[rad, rad, rad, rad, rad, rad]", signal="0.01", at="smr") -> str:
    """A residual_model section, one entry per coordinate (names separated by spaces) with the same numbers."""
    return ("residual_model:\n  kind: gp\n  outside_fraction: 0.5\n" f"  joint_units: {units}\n  coordinates:\n" + "".join(
        f"  - {{coordinate: {name}, at: {at}, inputs: {inputs}, targets: {targets}, signal_variance: {signal}, length_scales: {scales}, "
        f"noise_variance: {noise}}}\n" for name in coordinate.split()))


def _spec(tmp_path, section: str, tool: str = ""):
    """The independent simulator's PUMA tracker spec with ``section``; ``tool``: a robot.tool mapping (none: the flange)."""
    path = tmp_path / "spec.yaml"
    text = sim.spec_text("puma560", "tracker")
    path.write_text((text.replace("\n  targets:\n", f"\n  tool: {tool}\n  targets:\n", 1) if tool else text) + section)
    return path


@pytest.mark.parametrize("section, field, message", [
    (_section(inputs="[" + ", ".join([ROW] * 801) + "]"),
     "residual_model.coordinates[0].inputs", "Expected at most 800 entries, got 801."),
    (_section(targets="[.nan, 0.02]"), "residual_model.coordinates[0].targets[0]", "Expected a finite number, got nan."),
    (_section(inputs=f"[[.inf, 0, 0, 0, 0, 0], {ROW}]"), "residual_model.coordinates[0].inputs[0][0]", "Expected a finite number, got inf."),
    (_section(inputs=f"[{ROW}, [0.1, 0.2]]"), "residual_model.coordinates[0].inputs[1]", "2 joint values for 6 joints: one per joint"),
    (_section(inputs="[[" + ", ".join(["0"] * 65) + "], " + ROW + "]"), "residual_model.coordinates[0].inputs[0]", "Expected at most 64 entries, got 65."),
    (_section(coordinate="tip_z"), "residual_model.coordinates[0].coordinate", "'tip_z' is not a learned coordinate"),
    (_section(noise="-0.0004"), "residual_model.coordinates[0].noise_variance", "Must be above 0.0, got -0.0004."),
    (_section(scales="[1, 1]"), "residual_model.coordinates[0].length_scales", "2 length scales for 6 joints: one per joint"),
    (_section(targets="[0.01]"), "residual_model.coordinates[0]", "2 rows of inputs and 1 targets: one target a row."),
    (_section(units="[rad, mm, rad, rad, rad, rad]"), "residual_model.joint_units", "a model of another robot"),
    (_section(noise="1e-13"), "residual_model.coordinates[0]", "The noise_variance (1e-13) is below 1e-10 of the signal_variance (0.01)"),
    (_section(targets="[1e7, 0]"), "residual_model.coordinates[0].targets[0]", "Must be at most 1000000.0, got 10000000.0."),
    (_section(coordinate="base_x base_x"), "residual_model", "A coordinate is given twice (base_x at smr): one model each."),
    (_section(at="flange"), "residual_model.coordinates[0].at", "'flange' is not one of the robot's targets (smr)"),
    (_section(at='"a\\tb"'), "residual_model.coordinates[0].at", "String should match pattern"),
])
def test_a_mistake_in_the_section_is_one_located_message(tmp_path, section, field, message):
    with pytest.raises(SpecError) as caught:
        load_spec(_spec(tmp_path, section))
    (issue,) = caught.value.issues
    assert issue.field == field and message in issue.message and issue.line >= 27, issue


def test_validate_names_file_line_and_field_and_exits_1(tmp_path):
    path = _spec(tmp_path, _section(targets="[.nan, 0.02]"))
    shown = subprocess.run([sys.executable, "-m", "armcal", "validate", str(path)], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert shown.returncode == 1 and "Traceback" not in shown.stderr + shown.stdout
    assert f"{path}:31:" in shown.stderr and "residual_model.coordinates[0].targets[0]: Expected a finite number, got nan." in shown.stderr


def test_compensate_says_a_model_without_a_point_cannot_correct_a_target(tmp_path):
    """A ball-bar's length (or a theodolite's angles) is no point in the base frame: none is applied, and it says so."""
    loaded = load_spec(_spec(tmp_path, _section(coordinate="length")))
    text, unreached, _, note = compensate(loaded, None, TARGETS, "targets")
    assert not unreached and "learned_correction" not in text.splitlines()[0]
    assert note.startswith("not compensated: the learned residual model holds no point's error in the robot's base frame") and "holds length" in note


def test_a_run_says_a_stored_model_is_not_used_and_writes_none_of_it(tmp_path):
    """A calibrated.yaml run again: its stored model is not the new run's (never mixed with a new physical fit): the
    run says so, and the new calibrated.yaml keeps only a model the new run accepts (here none)."""
    path = _spec(tmp_path, _section())
    loaded = load_spec(path)
    (note,) = residual_model_note(loaded.spec, SimpleNamespace(residual=None))
    assert note.startswith("the spec's residual_model (an earlier run's learned model) is not used")
    written = calibrated_yaml(loaded.text, loaded.spec, {}, path, tmp_path, "a note")
    assert "residual_model" not in written


def test_a_correction_that_moves_a_target_out_of_reach_says_so(tmp_path):
    """A hand-edited model that moves every target by a metre (trusted everywhere: length scales of 1000 rad): the
    rows are unreachable, and say it is with the learned correction (without it they are reached)."""
    loaded = load_spec(_spec(tmp_path, _section(coordinate="base_x base_y base_z", inputs=f"[{ROW}]", targets="[1000]", signal="1e6",
                                                 scales="[1000, 1000, 1000, 1000, 1000, 1000]"), tool="{x: 50, y: 30, z: 80}"))
    text, unreached, _, note = compensate(loaded, None, TARGETS, "targets")
    assert unreached == ["t1 (no inverse-kinematics solution with the learned correction)"], unreached
    assert "0 of 0 solved targets in full" in note


@pytest.mark.parametrize("noise", ["0.0004", "-1"])
def test_a_merge_key_is_read_and_a_merged_mistake_is_located_at_its_mapping(tmp_path, noise):
    """YAML's merge key (<<: *anchor) in the section (as anywhere in a spec: a joint merged from another's) is read;
    a mistake in a merged value is located at the line of the mapping it is merged into (the loader raised a KeyError
    traceback: a merged key has no position of its own)."""
    first = _section(noise=noise).replace("  - {coordinate:", "  - &first {coordinate:")
    path = _spec(tmp_path, first + "  - {<<: *first, coordinate: base_y}\n")
    if noise != "-1":
        assert [c.coordinate for c in load_spec(path).spec.residual_model.coordinates] == ["base_z", "base_y"]
        return
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    merged = len(path.read_text().splitlines())
    assert [(i.field, i.line) for i in caught.value.issues] == [
        ("residual_model.coordinates[0].noise_variance", merged - 1), ("residual_model.coordinates[1].noise_variance", merged)]


@pytest.mark.parametrize("edit, message", [
    ({"targets": [float("nan"), 0.02]}, "residual_model.coordinates.0.targets.0: Expected a finite number, got nan (not a model armcal writes)"),
    ({"length_scales": [1, 1]}, "residual_model.coordinates.0.length_scales: 2 length scales for 6 joints: one per joint (not a model of this calibrated spec's robot)"),
])
def test_results_jsons_edited_model_is_one_plain_message(tmp_path, edit, message):
    """A run's folder without the section takes results.json's model: an edit is one plain sentence (pydantic's 'Value
    error, ' prefix and 'another robot' for a NaN were shown), naming the field."""
    coordinate = {"coordinate": "base_x", "at": "smr", "inputs": [[0.1] * 6, [0.2] * 6], "targets": [0.01, 0.02], "signal_variance": 0.01,
                  "length_scales": [1] * 6, "noise_variance": 0.0004, **edit}
    learned = {"kind": "gp", "accepted": True, "z": -3.0, "threshold": 2.0, "folds": 5, "folds_along_joint": 2,
               "held_out": {"per_coordinate": [], "outside": 0, "readings": 2}, "outside_fraction": 0.5, "joint_units": ["rad"] * 6,
               "hyperparameters": [], "seconds": 0.0, "carried": "results.json", "model": [coordinate]}
    results = Results.model_validate({**json.loads((ROOT / "tests" / "data" / "golden" / "results.json").read_text()), "residual_model": learned})
    with pytest.raises(UserError) as caught:
        learned_section(load_spec(_spec(tmp_path, "")), results)
    assert str(caught.value) == f"the run's results.json: {message}"
