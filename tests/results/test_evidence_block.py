"""results.json's diagnosis.evidence as the Evidence model: read by attribute, written back as the run wrote it."""

from __future__ import annotations

import json
import math

import pytest
from conftest import TESTS

from armcal.report.plots import draw_plots
from armcal.results.reader import read_results
from armcal.results.schema import BinnedSeries, Evidence
from armcal.support.errors import UserError


def _binned(joint: int | None, *effects: str) -> dict:
    """A binned series as evaluate/evidence.py writes it: joint, x, before, after, each effect's contribution, count."""
    head = {"joint": joint} if joint is not None else {}
    return {**head, "x": [-10.0, 5.0], "before": [0.3, 0.2], "after": [0.1, 0.1], **{e: [0.25, 0.15] for e in effects}, "count": [7, 3]}


def _evidence(older: bool = False) -> dict:
    block = {
        "unit": "mm",
        "joints": [_binned(1, "gear_harmonic.j2.h1", "backlash.j1"), _binned(2, "gear_harmonic.j2.h1", "backlash.j1")],
        "joint_axes": ["joint angle (deg)", "joint position (mm)"],
        "torque_masses": "the robot's declared masses (robot.masses)",
        "gravity_torque": [_binned(2, "gear_harmonic.j2.h1", "backlash.j1")],
        "keys": [{"key": "target1", "n": 30, "rms_before": 1.5, "rms_after": 0.1}],
        "magnitude": "RMS over each sample's readings",
        "histogram": {"edges": [-1.0, 0.0, 1.0], "counts": [3, 5], "expected": [4.0, 4.0], "noise_sigma": 0.5, "mean": 0.1, "std": 0.4},
        "t": _binned(None, "gear_harmonic.j2.h1", "backlash.j1"),
        "longitude": _binned(None, "gear_harmonic.j2.h1", "backlash.j1"),
    }
    if older:  # armcal before the joints' axes and the torque's masses were written
        del block["joint_axes"], block["torque_masses"]
    return block


@pytest.mark.parametrize("older", [False, True])
def test_the_evidence_writes_back_as_written(older):
    raw = _evidence(older)
    evidence = Evidence.model_validate(json.loads(json.dumps(raw)))
    assert json.dumps(evidence.model_dump(mode="json"), indent=2) == json.dumps(raw, indent=2)  # the effects' series inline, in order
    assert (evidence.torque_masses is None) == older and evidence.temperature is None
    panel = evidence.joints[1]
    assert panel.joint == 2 and list(panel.series) == ["before", "after", "gear_harmonic.j2.h1", "backlash.j1"]
    assert panel.after == [0.1, 0.1] and panel.count == [7, 3] and evidence.t.joint is None


def test_a_binned_series_built_from_its_fields_writes_its_series_inline():
    built = BinnedSeries(x=[1.0], series={"before": [2.0], "after": [1.0], "thermal_drift": [0.5]}, count=[4])
    assert list(built.model_dump()) == ["x", "before", "after", "thermal_drift", "count"]


def test_a_bin_centre_that_is_not_a_number_is_null_in_the_run_and_in_the_file():
    """A theodolite's scale-bar readings have no joint values: the joints' bins have no numbers for centres."""
    raw = _evidence()
    raw["joints"][0]["x"] = [math.nan, math.nan]
    evidence = Evidence.model_validate(raw)
    assert evidence.joints[0].x == [None, None]
    assert json.loads(json.dumps(evidence.model_dump(mode="json")))["joints"][0]["x"] == [None, None]
    assert "residual_vs_joint.svg" in draw_plots(evidence, "mm")  # drawn as nan, as before the block was typed


@pytest.mark.parametrize("change, message", [
    (lambda block: block["joints"][0].pop("after"), "lacks its before or its after series"),
    (lambda block: block["t"]["backlash.j1"].append(0.2), "not as long as its x"),
    (lambda block: block["histogram"].pop("noise_sigma"), "noise_sigma"),
])
def test_a_broken_evidence_block_is_refused_naming_it(tmp_path, change, message):
    results = json.loads((TESTS / "data" / "golden" / "results.json").read_text())
    results["diagnosis"]["evidence"] = _evidence()
    change(results["diagnosis"]["evidence"])
    (tmp_path / "results.json").write_text(json.dumps(results))
    with pytest.raises(UserError, match="not a results.json as armcal writes it") as raised:
        read_results(tmp_path / "results.json")
    assert "diagnosis.evidence" in str(raised.value) and message in str(raised.value)
