"""`armcal run` end to end on the shipped examples, per the output contract."""

import csv
import json
import math
import re

import pytest
from conftest import ROOT, armcal_cli, copy_example

from armcal.commands.run import run
from armcal.results.schema import Results
from armcal.spec import load_spec

EXAMPLES = sorted(p.parent.name for p in (ROOT / "examples").glob("*/spec.yaml"))
CONTRACT = {
    "armcal_version", "created", "spec", "robot", "device", "status", "identifiability",
    "parameters", "residuals", "improvement_factor", "diagnosis", "evaluation",
}


@pytest.mark.parametrize("name", EXAMPLES)
def test_run_writes_the_contract(tmp_path, name):
    outcome = run(ROOT / "examples" / name / "spec.yaml", tmp_path)
    assert outcome.exit_code == 0
    data = json.loads((tmp_path / "results.json").read_text())
    assert CONTRACT <= set(data)
    Results.model_validate(data)
    assert set(data["spec"]) >= {"path", "sha256", "git"} and set(data["robot"]) == {"name", "serial", "convention", "dof"}
    assert data["spec"]["placeholders"] == []  # a shipped example gives every value (docs/results.md spec.placeholders)
    assert set(data["identifiability"]) >= {"n_parameters", "rank", "free", "fixed", "condition_number"}
    assert set(data["parameters"][0]) == {"name", "unit", "nominal", "value", "std", "free"}
    for stats in (data["residuals"]["calibration"]["before"], data["residuals"]["calibration"]["after"]):
        assert set(stats) == {"n", "rms", "mean", "std", "max_abs"}
    assert set(data["diagnosis"]) >= {"rounds", "added_effects", "unexplained"}
    assert data["improvement_factor"]["calibration"] > 5
    posed = _rows_with_a_pose(ROOT / "examples" / name / "calibration.csv")
    for panel in data["diagnosis"]["evidence"]["joints"]:  # the samples with a pose, binned along each joint
        assert sum(panel["count"]) == posed and all(math.isfinite(x) for x in panel["x"]), (name, panel["joint"])
    calibrated = load_spec(tmp_path / "calibrated.yaml")  # a valid spec, ready to commit
    assert calibrated.spec.robot.serial == data["robot"]["serial"]
    _check_certificate(tmp_path, data)


def _rows_with_a_pose(path) -> int:
    """Rows of a data file whose joint columns (q1, q2, ...) all hold numbers (a theodolite's scale-bar rows hold none)."""
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    joints = [column for column in rows[0] if re.fullmatch(r"q\d+", column)]
    return sum(all(_number(row[q]) for q in joints) for row in rows)


def _number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


E_NOTATION = re.compile(r"(?<![0-9a-fA-F.])\d+(?:\.\d+)?[eE][-+]?\d+(?![0-9a-fA-F])")  # not inside a hex hash
ROW = re.compile(r'<tr><td>([^<]*)</td><td>([^<]*)</td><td class="num">([^<]*)</td><td class="num">([^<]*)</td><td class="num">([^<]*)</td></tr>')
UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}


def _places(uncertainty: float) -> int:
    """GUM 7.2.6 by string formatting: the decimals that keep two significant digits of the uncertainty."""
    mantissa, exponent = f"{uncertainty:.1e}".split("e")
    return max(0, 1 - int(exponent))


def _shown(value: float, places: int) -> str:
    text = f"{value:.{places}f}"
    return text.lstrip("-") if float(text) == 0 else text


def _check_certificate(folder, data):
    """The PDF opens, has 4-12 pages, shows the serial, the spec's sha256, every identified value to the decimal of its
    uncertainty (two significant digits), no e-notation, no '1 iterations', no bare 'p = 0'; every task factor reads
    'at the noise' where the design figure is within the instrument's noise, else design / calibrated (bounded
    '> N' where the calibrated figure is within it), the noise computed here from results.json."""
    from pypdf import PdfReader

    reader = PdfReader(folder / "certificate.pdf")
    assert 4 <= len(reader.pages) <= 12
    text = " ".join(page.extract_text() for page in reader.pages)
    flat = text.replace("\n", " ")
    assert data["robot"]["serial"] in flat and data["spec"]["sha256"] in flat.replace(" ", "")
    assert not E_NOTATION.search(flat), E_NOTATION.search(flat)
    assert " 1 iterations" not in flat and not re.search(r"p = 0(?![.\d])", flat)
    unit = data["report"]["unit"]
    for p in data["parameters"]:
        if p["free"] and p["std"] is not None and p["unit"] in (unit, "deg", "1"):
            shown = _shown(p["value"], _places(2 * p["std"]))
            assert p["name"] in flat and shown in flat, (p["name"], shown)
    html = (folder / "certificate.html").read_text()
    noise_mm = data["device"]["noise_sigma"] * UNITS_MM.get(data["device"]["unit"], float("nan"))
    for task, rows in (("grid_task", "indices"), ("iso9283", "poses")):
        block = data["evaluation"].get(task) or {}
        centre = block.get("centre") if task == "grid_task" else (block.get("cube") or {}).get("centre")
        for row in block.get(rows, []):
            label = row.get("index", row.get("pose"))
            found = [r for r in ROW.findall(html) if r[0].startswith(label) and r[0][len(label):len(label) + 1] in ("", " ")]
            assert len(found) == 1, label
            factor = found[0][4].replace("&gt;", ">")
            if row["unit"] == "deg":
                distance_mm = sum(c * c for c in centre) ** 0.5 * UNITS_MM[block.get("unit", (block.get("cube") or {}).get("unit"))]
                noise = math.degrees(noise_mm / distance_mm)
            else:
                noise = noise_mm / UNITS_MM[row["unit"]]
            before, after = abs(row["design"]), abs(row["calibrated"])
            if before <= noise:
                assert factor == "at the noise", (label, factor)
            elif after <= noise:
                assert factor == f"> {before / noise:.1f}", (label, factor)
            else:
                assert factor == f"{before / after:.1f}", (label, factor)


def test_calibrated_spec_holds_the_identified_values(tmp_path):
    outcome = run(ROOT / "examples" / "goswami_ballbar" / "spec.yaml", tmp_path, pdf=False)
    text = (tmp_path / "calibrated.yaml").read_text()
    assert text.startswith("# Calibrated by armcal")
    assert "centre-to-centre at mid-travel" in text  # the input spec's comments are kept
    calibrated = load_spec(tmp_path / "calibrated.yaml").spec
    x3 = next(p for p in outcome.results.parameters if p.name == "L3.x")
    assert calibrated.robot.links[2].x.value == pytest.approx(x3.value * 10, rel=1e-9)  # cm -> mm


def test_a_fit_that_cannot_converge_exits_3_with_its_reason(tmp_path):
    (tmp_path / "example").mkdir()
    spec = copy_example("theodolite", tmp_path / "example") / "spec.yaml"
    spec.write_text(spec.read_text().replace("simulate:", "fit: {max_iterations: 1}\nsimulate:"))
    result = armcal_cli("run", spec, "--out", tmp_path / "out")
    assert result.returncode == 3, result.stderr
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    assert data["status"] == "not_converged" and "iteration limit" in data["solver"]["reason"]


def test_run_without_data_is_a_user_error(tmp_path):
    from armcal.support.errors import UserError

    with pytest.raises(UserError, match="no data section"):
        run(ROOT / "specs" / "puma560_dh.yaml", tmp_path)


def test_stones_feature_method_beside_least_squares(tmp_path):
    """The sonic example asks for s_model_features: features per joint, pseudo-DH, and both residuals."""
    outcome = run(ROOT / "examples" / "puma560_sonic" / "spec.yaml", tmp_path, pdf=False)
    results = outcome.results
    assert results.status == "converged" and results.solver.method == "s_model_features"
    block = results.evaluation.s_model_features
    radii = [j.radius for j in block.joints]
    assert radii == pytest.approx([40.87, 41.62, 43.71, 33.30, 45.13, 33.30], abs=0.05)  # Table 6-1, cm
    features_rms = block.residuals.s_model_features.rms
    least_squares_rms = block.residuals.least_squares.rms
    assert least_squares_rms <= features_rms < 1.5 * least_squares_rms  # features come close; the full fit does better
    assert results.residuals.calibration.after.rms == pytest.approx(features_rms)
    # the last frame turns with joint 6 as the design's does: sparker 6 where Table F-1 puts it,
    # and signature-based control keeps the tool's orientation (it was off by 180 deg about z6)
    values = {p.name: p.value for p in results.parameters}
    assert [values[f"sparker6.{c}"] for c in "xyz"] == pytest.approx([33.3, 0.0, 10.225], abs=0.1)
    for row in results.evaluation.grid_task.indices:
        if row.index.endswith(" orientation") and "relative" not in row.index:
            assert row.calibrated < row.design / 3, row


def test_grid_task_design_versus_calibrated_control(tmp_path):
    """With the simulation's truth beside the data, the run controls the true robot both ways (Stone 6.6)."""
    outcome = run(ROOT / "examples" / "goswami_ballbar" / "spec.yaml", tmp_path)
    rows = {r.index: r for r in outcome.results.evaluation.grid_task.indices}
    assert len(rows) == 34
    for vertex in (1, 4, 5, 8):
        radial = rows[f"vertex {vertex} radial"]
        assert radial.calibrated < radial.design / 5  # calibrated control lands closer, on the true robot
    iso = outcome.results.evaluation.iso9283.poses  # the example's report asks for the ISO cube too
    assert [r.pose for r in iso] == ["P1", "P2", "P3", "P4", "P5"]
    assert all(r.calibrated < r.design / 5 for r in iso)
    from pypdf import PdfReader

    assert "ISO 9283 positional accuracy" in " ".join(p.extract_text() for p in PdfReader(tmp_path / "certificate.pdf").pages)


def test_no_grid_task_without_the_datas_truth(tmp_path):
    import shutil

    for name in ("spec.yaml", "calibration.csv", "validation.csv"):  # the data without their truth.json
        shutil.copy(ROOT / "examples" / "theodolite" / name, tmp_path / name)
    evaluation = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results.evaluation
    assert all("needs the true robot" in getattr(evaluation, task).skipped for task in ("grid_task", "iso9283"))


@pytest.mark.parametrize("readings", ["ranges", "points"])
def test_sonic_fit_on_raw_ranges_or_triangulated_points(tmp_path, readings):
    """Both ways of fitting the digitizer converge and match the noise model (chi^2 / dof near 1)."""
    import shutil

    folder = ROOT / "examples" / "puma560_sonic"
    text = (folder / "spec.yaml").read_text().replace("fit: {method: s_model_features}\n", "").replace("  speed_of_sound:", f"  readings: {readings}\n  speed_of_sound:", 1)
    assert f"readings: {readings}" in text and "s_model_features" not in text
    (tmp_path / "spec.yaml").write_text(text)
    shutil.copy(folder / "calibration.csv", tmp_path / "calibration.csv")
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    assert results.status == "converged"
    assert 0.5 < results.noise_check.chi2 / results.noise_check.dof < 1.5
    assert results.residuals.calibration.after.rms < results.residuals.calibration.before.rms / 5


def test_the_undeclared_effect_example_is_diagnosed_through_run(tmp_path):
    """examples/hidden_harmonic: the diagnosis adds joint 2's first harmonic, validation RMS reaches the noise."""
    results = run(ROOT / "examples" / "hidden_harmonic" / "spec.yaml", tmp_path, pdf=False).results
    diagnosis = results.diagnosis
    assert [(e.type, e.joint, e.order) for e in diagnosis.added_effects] == [("gear_harmonic", 2, 1)]
    first = diagnosis.rounds[0]
    assert first.accepted is not None and first.rms_after.validation < first.rms_before.validation / 2
    sin = next(p for p in diagnosis.added_effects[0].parameters if p.name.endswith(".sin"))
    assert abs(sin.value - 0.02) < 3 * sin.std  # simulated: 0.02 deg
    assert results.residuals.validation.after.rms < 1.15 * 0.025  # tracker noise 0.025 mm
    calibrated = load_spec(tmp_path / "calibrated.yaml").spec
    assert [(e.type, e.joint, e.order) for e in calibrated.effects] == [("gear_harmonic", 2, 1)]
    assert not diagnosis.unexplained


def test_a_declared_effect_without_values_is_identified_from_zero(tmp_path):
    """An effect declared with its parameters left out starts at 0 and is fitted (simulated: 0.02, 0.008 deg)."""
    import shutil

    folder = ROOT / "examples" / "hidden_harmonic"
    for name in ("calibration.csv", "validation.csv", "truth.json"):
        shutil.copy(folder / name, tmp_path / name)
    text = (folder / "spec.yaml").read_text() + "effects:\n  - {type: gear_harmonic, joint: 2, order: 1}\n"
    (tmp_path / "spec.yaml").write_text(text)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    values = {p.name: p for p in results.parameters}
    for field, truth in (("sin", 0.02), ("cos", 0.008)):
        parameter = values[f"gear_harmonic.j2.h1.{field}"]
        assert parameter.free and abs(parameter.value - truth) < 3 * parameter.std
    assert results.residuals.validation.after.rms < 1.15 * 0.025


def test_evidence_and_plots(tmp_path):
    results = run(ROOT / "examples" / "hidden_harmonic" / "spec.yaml", tmp_path, pdf=False).results
    evidence = results.diagnosis.evidence
    histogram = evidence.histogram
    assert sum(histogram.counts) == results.residuals.calibration.after.n
    assert sum(histogram.expected) == pytest.approx(sum(histogram.counts), rel=0.01)
    joint2 = evidence.joints[1]
    assert list(joint2.series) == ["before", "after", "gear_harmonic.j2.h1"] and max(joint2.before) > 2 * max(joint2.after)
    for name in results.diagnosis.plots:
        text = (tmp_path / name).read_text()
        assert text.lstrip().startswith("<?xml") and "<svg" in text
    assert {"residual_histogram.svg", "residual_vs_joint.svg", "residual_vs_torque.svg"} <= set(results.diagnosis.plots)


def test_a_truth_of_another_robot_model_skips_the_tasks(tmp_path):
    """truth.json beside the data but from a spec with other parameters: the tasks say why they did not run."""
    import shutil

    folder = ROOT / "examples" / "hidden_harmonic"
    for name in ("calibration.csv", "validation.csv", "truth.json"):
        shutil.copy(folder / name, tmp_path / name)
    text = (folder / "spec.yaml").read_text()
    text = text.replace("    reflector: {link: 6, x: 5.0, y: 0.0, z: 10.0}\n", "    reflector: {link: 6, x: 5.0, y: 0.0, z: 10.0}\n    spare: {link: 3, x: 1.0}\n")
    (tmp_path / "spec.yaml").write_text(text)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    assert "another model" in results.evaluation.grid_task.skipped
