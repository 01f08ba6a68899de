"""The certificate as a laboratory issues it (ISO/IEC 17025 7.8): instrument, environment, conformity, simulated data,
history; each number checked against results.json and an oracle computed here from the data files."""

import csv
import json
import re
import shutil

import numpy as np
import pytest
from scipy.stats import t as student_t
from conftest import ROOT, armcal_cli, copy_example, shipped_specs

from armcal.support.errors import SpecError
from armcal.evaluate.acceptance import rms_uncertainty
from armcal.commands.run import run
from armcal.report.context import certificate_context
from armcal.results.schema import Results
from armcal.report.render import PACKAGED, render_html
from armcal.simulate import find_truth
from armcal.spec import load_spec

BANNER = "SIMULATED DATA — not a calibration of a physical robot"
INSTRUMENT = {"maker": "Leica", "model": "AT960", "serial": "LT-7731", "calibrated": "2025-11-03", "certificate": "DKD-K-12345", "mpe": "±(15 µm + 6 µm/m)"}
TOLERANCE_MM = 0.03


def _pdf_pages(path) -> list[str]:
    from pypdf import PdfReader

    return [" ".join(page.extract_text().split()) for page in PdfReader(path).pages]


def _with_temperature(path, rng) -> np.ndarray:
    """A temperature column (degC) appended to a data file; returns the values written."""
    rows = path.read_text().splitlines()
    values = np.round(rng.uniform(19.0, 23.0, len(rows) - 1), 3)
    path.write_text("\n".join([rows[0] + ",temperature", *(f"{r},{v}" for r, v in zip(rows[1:], values))]) + "\n")
    return values


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The hidden-harmonic campaign without its truth.json (not armcal's simulation as far as armcal can tell), with a
    temperature column, the instrument's identity and a guarded acceptance of the held-out RMS."""
    folder = copy_example("hidden_harmonic", tmp_path_factory.mktemp("measured"))
    rng = np.random.default_rng(7)
    temperatures = np.concatenate([_with_temperature(folder / name, rng) for name in ("calibration.csv", "validation.csv")])
    spec = (folder / "spec.yaml").read_text()
    fields = ", ".join(f'{k}: "{v}"' if k != "calibrated" else f"{k}: {v}" for k, v in INSTRUMENT.items())
    spec = spec.replace("device:\n  type: tracker\n", f"device:\n  type: tracker\n  instrument: {{{fields}}}\n")
    (folder / "spec.yaml").write_text(spec + f"acceptance: {{tolerance: {TOLERANCE_MM} mm, statistic: validation_rms, decision_rule: guarded}}\n")
    run(folder / "spec.yaml", folder / "out")
    results = json.loads((folder / "out" / "results.json").read_text())
    return folder, results, temperatures


@pytest.fixture(scope="module")
def simulated(tmp_path_factory, measured):
    """The shipped hidden-harmonic example (simulated data) run through the CLI with the measured run as its history."""
    out = tmp_path_factory.mktemp("simulated") / "out"
    result = armcal_cli("run", ROOT / "examples" / "hidden_harmonic" / "spec.yaml", "--out", out, "--history", measured[0] / "out")
    assert result.returncode == 0, result.stderr
    return out, json.loads((out / "results.json").read_text()), result.stdout


def _validation_residuals_mm(folder) -> dict[int, np.ndarray]:
    """residuals.csv's held-out residuals after calibration, in mm, by data-file line (one pose each)."""
    poses: dict[int, list[float]] = {}
    with open(folder / "residuals.csv") as stream:
        for row in csv.DictReader(stream):
            if row["data"] == "validation":
                scale = {"mm": 1.0, "cm": 10.0, "m": 1000.0}[row["unit"]]
                poses.setdefault(int(row["line"]), []).append(float(row["residual_after"]) * scale)
    return {line: np.array(values) for line, values in poses.items()}


def test_temperature_range_is_the_datas_lowest_and_highest(measured):
    folder, results, temperatures = measured
    assert results["campaign"]["temperature"] == [temperatures.min(), temperatures.max()]
    text = " ".join(_pdf_pages(folder / "out" / "certificate.pdf"))
    assert f"{temperatures.min():.2f} - {temperatures.max():.2f} °C" in text


def test_the_instruments_identity_is_printed_as_given(measured):
    folder, results, _ = measured
    assert results["campaign"]["traceability"] == INSTRUMENT
    text = " ".join(_pdf_pages(folder / "out" / "certificate.pdf"))
    assert all(value in text for value in INSTRUMENT.values()) and "not given in the spec" not in text


def test_guarded_acceptance_against_an_independent_rms_and_jackknife_uncertainty(measured):
    """The held-out RMS and its U recomputed from residuals.csv: u by the jackknife over poses (not the delta method
    armcal uses), k Student's t for 95 % over the poses (scipy); the verdict from the tolerance and those numbers."""
    folder, results, _ = measured
    acceptance = results["acceptance"]
    poses = list(_validation_residuals_mm(folder / "out").values())
    rms = lambda chosen: np.sqrt(np.mean(np.concatenate(chosen) ** 2))  # noqa: E731
    value = rms(poses)
    leave_one_out = np.array([rms(poses[:i] + poses[i + 1 :]) for i in range(len(poses))])
    jackknife = np.sqrt((len(poses) - 1) / len(poses) * np.sum((leave_one_out - leave_one_out.mean()) ** 2))
    assert acceptance["value"] == pytest.approx(value, rel=1e-6) == results["residuals"]["validation"]["after"]["rms"]
    k = student_t.ppf(0.975, len(poses) - 1)
    assert acceptance["coverage_factor"] == pytest.approx(k, rel=1e-9)
    assert acceptance["expanded_uncertainty"] == pytest.approx(k * jackknife, rel=0.03)
    assert acceptance["tolerance"] == pytest.approx(TOLERANCE_MM) and acceptance["decision_rule"] == "guarded"
    expected = "pass" if value + k * jackknife <= TOLERANCE_MM else "fail"
    assert acceptance["verdict"] == expected
    text = " ".join(_pdf_pages(folder / "out" / "certificate.pdf"))
    unit = results["report"]["unit"]  # the certificate's one length unit
    scale = {"mm": 1.0, "cm": 10.0, "m": 1000.0}[unit]
    places = max(0, 1 - int(f"{acceptance['expanded_uncertainty'] / scale:.1e}".split("e")[1]))  # U to two significant digits (GUM 7.2.6)
    assert f"{expected.upper()}: the figure {value / scale:.{places}f} {unit}" in text and "guarded acceptance (ILAC-G8:2019 4.2.3)" in text


def test_data_without_their_truth_are_not_marked_simulated(measured):
    folder, results, _ = measured
    assert results["simulated"] == {"calibration": False, "validation": False}
    assert not any("SIMULATED" in page for page in _pdf_pages(folder / "out" / "certificate.pdf"))


@pytest.mark.parametrize("spec", [p for p in shipped_specs() if p.parent.parent.name == "examples"], ids=lambda p: p.parent.name)
def test_every_shipped_examples_data_are_armcals_simulation(spec):
    loaded = load_spec(spec)
    assert all(find_truth(spec.parent / name) is not None for name in (loaded.spec.data.calibration, loaded.spec.data.validation) if name)


def test_simulated_data_carry_the_banner_on_every_page(simulated):
    out, results, _ = simulated
    assert results["simulated"] == {"calibration": True, "validation": True}
    pages = _pdf_pages(out / "certificate.pdf")
    assert len(pages) >= 4 and all(BANNER in page for page in pages)


def test_without_acceptance_or_instrument_the_certificate_says_so(simulated):
    out, results, _ = simulated
    assert results["acceptance"] is None and results["campaign"]["traceability"] is None
    html = (out / "certificate.html").read_text()
    assert "No acceptance criterion was given in the spec" in html and "PASS" not in html and "FAIL" not in html
    assert html.count("<td>not given in the spec</td>") == 6


def test_history_lists_the_earlier_run_of_the_same_serial(measured, simulated):
    _, earlier, _ = measured
    out, results, _ = simulated
    (entry,) = results["history"]
    assert entry["run_id"] == earlier["run_id"] and entry["created"] == earlier["created"]
    assert entry["rms_validation"] == earlier["residuals"]["validation"]["after"]["rms"]
    assert entry["compared"] == sum(p["free"] for p in results["parameters"])
    text = " ".join(_pdf_pages(out / "certificate.pdf"))
    assert "Calibration history of this robot" in text and earlier["run_id"] in text
    assert "history: 1 earlier calibration(s) of this serial" in simulated[2] and "SIMULATED DATA" in simulated[2]


def test_history_flags_significant_changes_and_refuses_another_serial(simulated, tmp_path):
    """An earlier calibration with one parameter 5 combined uncertainties away and one 1 away: only the first is listed,
    with z = change / sqrt(u_old^2 + u_new^2); results.json given to report is not replaced; another serial is exit 1."""
    out, results, _ = simulated
    folder = tmp_path / "run"
    shutil.copytree(out, folder)
    earlier = json.loads(json.dumps(results))
    free = [p for p in earlier["parameters"] if p["free"] and p["std"]]
    for p, shift in ((free[0], 5.0), (free[1], 1.0)):
        p["value"] -= shift * np.hypot(p["std"], p["std"])
    earlier["created"] = "2020-01-01T00:00:00Z"
    (tmp_path / "earlier.json").write_text(json.dumps(earlier))
    before = (folder / "results.json").read_bytes()
    result = armcal_cli("report", folder, "--force", "--no-pdf", "--history", tmp_path / "earlier.json")
    assert result.returncode == 0, result.stderr
    assert (folder / "results.json").read_bytes() == before
    html = (folder / "certificate.html").read_text()
    row = html.split("2020-01-01", 1)[1].split("</tr>", 1)[0]
    assert f"{free[0]['name']} " in row and f"{free[1]['name']} " not in row and "z = 5.0" in row
    earlier["robot"]["serial"] = "ANOTHER-ROBOT"
    (tmp_path / "other.json").write_text(json.dumps(earlier))
    for command in (("report", folder, "--force", "--no-pdf"), ("run", ROOT / "examples" / "hidden_harmonic" / "spec.yaml", "--out", tmp_path / "new")):
        refused = armcal_cli(*command, "--history", tmp_path / "other.json")
        assert refused.returncode == 1 and "other.json: serial ANOTHER-ROBOT is not HIDDEN-HARMONIC-1" in refused.stderr, refused.stderr
    assert not (tmp_path / "new").exists()


def test_rms_uncertainty_of_one_reading_per_pose_is_the_delta_method():
    rng = np.random.default_rng(1)
    values = rng.normal(0.0, 0.05, 400)
    squares = values**2
    expected = np.std(squares, ddof=1) / np.sqrt(len(values)) / (2 * np.sqrt(np.mean(squares)))
    assert rms_uncertainty(squares, np.ones(len(values))) == pytest.approx(expected, rel=1e-12)
    assert rms_uncertainty(squares, np.ones(len(values))) == pytest.approx(0.05 / np.sqrt(2 * 400), rel=0.15)  # Gaussian


def test_a_simple_acceptance_failing_reads_fail_with_its_rule():
    results = json.loads((ROOT / "tests" / "data" / "golden" / "results.json").read_text())
    value = results["residuals"]["validation"]["after"]["rms"]
    results["acceptance"] = {"statistic": "validation_rms", "value": value, "unit": "mm", "tolerance": value / 2, "decision_rule": "simple",
                             "expanded_uncertainty": None, "coverage_factor": None, "acceptance_limit": value / 2, "verdict": "fail"}
    html = render_html(certificate_context(Results.model_validate(results), {}), [PACKAGED])
    assert f"FAIL: the figure {value:.4f} mm is above the acceptance limit {value / 2:.4f} mm." in html
    assert "simple acceptance (ILAC-G8:2019 4.2.1)" in html and "not used (simple acceptance)" in html


@pytest.mark.parametrize(
    "example, acceptance, message",
    [
        ("hidden_harmonic", "{tolerance: 0.1 mm, statistic: validation_max, decision_rule: guarded}", "Guarded acceptance needs the figure's uncertainty"),
        ("goswami_ballbar", "{tolerance: 0.1 mm, statistic: validation_rms_3d}", "validation_rms_3d needs measured points (a tracker)"),
        ("theodolite", "{tolerance: 0.1 mm}", "a theodolite's residuals are angles"),
    ],
)
def test_an_acceptance_armcal_cannot_judge_is_a_located_spec_error(tmp_path, example, acceptance, message):
    copy_example(example, tmp_path)
    spec = tmp_path / "spec.yaml"
    spec.write_text(spec.read_text() + f"acceptance: {acceptance}\n")
    with pytest.raises(SpecError, match=re.escape(message)) as failed:
        load_spec(spec)
    assert f"{spec}:" in str(failed.value)


def test_a_history_file_inside_the_output_folder_is_never_replaced(simulated, tmp_path):
    out, _, _ = simulated
    folder = tmp_path / "run"
    shutil.copytree(out, folder)
    before = (folder / "results.json").read_bytes()
    refused = armcal_cli("run", ROOT / "examples" / "hidden_harmonic" / "spec.yaml", "--out", folder, "--force", "--history", folder)
    assert refused.returncode == 1 and "an input of this run" in refused.stderr
    assert (folder / "results.json").read_bytes() == before
