"""Nonsense is not reported as success: degenerate data are a located user error, a rejected noise check is
said on the terminal and in a fleet's summary with what to check."""

import pytest
from conftest import ROOT, armcal_cli, copy_example

EXAMPLE = ROOT / "examples" / "hidden_harmonic"


@pytest.fixture()
def workspace(tmp_path):
    return copy_example("hidden_harmonic", tmp_path)


@pytest.mark.parametrize("distinct", [1, 3])
def test_repeated_poses_cannot_determine_the_parameters(workspace, distinct):
    lines = (EXAMPLE / "calibration.csv").read_text().splitlines()
    rows = [lines[1 + i % distinct].split(",", 1)[1] for i in range(399)]  # 399 samples at `distinct` poses
    (workspace / "calibration.csv").write_text("\n".join([lines[0]] + [f"{i},{row}" for i, row in enumerate(rows, 1)]) + "\n")
    result = armcal_cli("run", workspace / "spec.yaml", "--no-pdf")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert f"calibration.csv: {3 * distinct} readings cannot determine" in result.stderr
    assert f"only {3 * distinct} of them at distinct poses" in result.stderr


@pytest.mark.parametrize(
    "noise, said",
    [("10", "the declared noise is too large"), ("0.00025", "the residuals exceed the noise model")],  # cm; the data's is 0.0025
)
def test_a_rejected_noise_check_is_said_with_what_to_check(workspace, noise, said):
    text = (workspace / "spec.yaml").read_text()
    (workspace / "spec.yaml").write_text(text.replace("noise: 0.0025", f"noise: {noise}"))
    result = armcal_cli("run", workspace / "spec.yaml", "--no-pdf")
    assert result.returncode == 0, result.stderr
    assert said in result.stdout
    fleet = armcal_cli("batch", workspace / "spec.yaml", "--out", workspace / "fleet", "--no-pdf", "--workers", "1")
    assert said in fleet.stdout and (workspace / "fleet" / "fleet.json").exists()


def test_a_consistent_fit_says_nothing_of_the_kind(workspace):
    result = armcal_cli("run", workspace / "spec.yaml", "--no-pdf")
    assert result.returncode == 0 and "noise model" not in result.stdout
