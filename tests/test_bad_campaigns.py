"""Campaigns that cannot calibrate: clear messages naming the file (and row), exit 1, earlier output untouched."""

import shutil

from conftest import ROOT, armcal_cli

EXAMPLES = ROOT / "examples"


def _run(folder):
    return armcal_cli("run", folder / "spec.yaml", "--out", folder / "out")


def _copy(tmp_path, example, names=("spec.yaml", "calibration.csv", "validation.csv")):
    for name in names:
        if (EXAMPLES / example / name).exists():
            shutil.copy(EXAMPLES / example / name, tmp_path / name)
    return tmp_path


def test_a_ball_bar_reading_outside_the_lvdt_travel_is_named_by_row(tmp_path):
    folder = _copy(tmp_path, "goswami_ballbar")
    lines = (folder / "calibration.csv").read_text().splitlines()
    header = lines[0].split(",")
    fields = lines[5].split(",")
    fields[header.index("length")] = "52.0"  # cm: 6 cm from mid-travel, the LVDT has 3.75
    lines[5] = ",".join(fields)
    (folder / "calibration.csv").write_text("\n".join(lines) + "\n")
    result = _run(folder)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "calibration.csv:6: length: reading outside the instrument's range" in result.stderr
    assert not (folder / "out").exists()


def test_too_few_samples_for_the_free_parameters(tmp_path):
    folder = _copy(tmp_path, "theodolite")
    lines = (folder / "calibration.csv").read_text().splitlines()
    (folder / "calibration.csv").write_text("\n".join(lines[:9]) + "\n")  # 8 sightings, 16 angles
    result = _run(folder)
    assert result.returncode == 1 and "readings cannot determine" in result.stderr and "free parameters" in result.stderr


def test_a_circle_point_sweep_under_180_degrees_violates_b3(tmp_path):
    folder = _copy(tmp_path, "puma560_sonic")
    text = (folder / "spec.yaml").read_text().replace("limits: [-100, 100]", "limits: [-60, 60]")  # joint 5: 120 deg
    (folder / "spec.yaml").write_text(text.replace("seed: 560", "seed: 560\n  noise: true"))
    simulate = armcal_cli("simulate", folder / "spec.yaml", "--out", folder, "--force")
    assert simulate.returncode == 0, simulate.stderr
    result = _run(folder)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "joint 5 sweeps" in result.stderr and "assumption B-3" in result.stderr


def test_a_start_far_from_the_solution_is_reported_not_crashed(tmp_path):
    """Nominal link lengths 5 cm off: the fit either converges or says it did not; the certificate says which."""
    folder = _copy(tmp_path, "goswami_ballbar")
    text = (folder / "spec.yaml").read_text().replace("{x: 43.18, y: 0,", "{x: 48.18, y: 0,")
    (folder / "spec.yaml").write_text(text)
    result = _run(folder)
    assert result.returncode in (0, 3) and "Traceback" not in result.stderr
    assert (folder / "out" / "certificate.pdf").exists()
