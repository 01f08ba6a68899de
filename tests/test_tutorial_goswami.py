"""docs/tutorials/goswami.py: its numbers against oracles that do not come from armcal.

- Counts: Goswami (1), N = 5 n_r + 3 n_p + 6 (4 n_r + 2 n_p + 6 without encoder scales), less
  the rigid rotations that fix every pivot used (world side) and every sphere used (flange
  side): computed here from the pivot and sphere coordinates of the spec, as the null space
  of the infinitesimal rigid motions (w, v) with w x p + v = 0 at each point.
- Goswami's text (Pose Measurements: How Many Dimensions Are Enough?): all nine pairings 36,
  any six that use every chuck and sphere 36, one sphere from three chucks 33.
- Calibration: the readings are simulated with the bar noise sigma the spec states; the RMS
  residuals on the calibration and on the held-out shells are within 15 % of it.
"""

import importlib.util
import json
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT
from ruamel.yaml import YAML

SCRIPT = ROOT / "docs" / "tutorials" / "goswami.py"
SPEC = ROOT / "examples" / "goswami_ballbar" / "spec.yaml"
SEED = ROOT.parent / "shared" / "seeds" / "000_25cbc1c99a2763f3.txt"
TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}


@pytest.fixture(scope="module")
def output(tmp_path_factory):
    numbers = tmp_path_factory.mktemp("goswami") / "numbers.json"
    result = subprocess.run([sys.executable, str(SCRIPT), "--json", str(numbers)], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result.stdout, json.loads(numbers.read_text())


@pytest.fixture(scope="module")
def spec():
    return YAML(typ="safe").load(SPEC.read_text())


def _value(x):
    return x["value"] if isinstance(x, dict) else x


def _unseen_rotations(points: list[np.ndarray]) -> int:
    """Dimension of the rigid motions that move none of the points: 6 - rank of [-skew(p) | I] stacked."""
    rows = []
    for p in points:
        skew = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        rows.append(np.hstack([-skew, np.eye(3)]))
    return 6 - np.linalg.matrix_rank(np.vstack(rows), tol=1e-9)


def _oracle(spec, pairs, scales: bool) -> int:
    joints = spec["robot"]["joints"]
    n_r = sum(j.get("type", "revolute") == "revolute" for j in joints)
    n_p = len(joints) - n_r
    n = 5 * n_r + 3 * n_p + 6 if scales else 4 * n_r + 2 * n_p + 6
    pivots = spec["device"]["pivots"]
    targets = spec["robot"]["targets"]
    chucks = [np.array([_value(pivots[c][k]) for k in "xyz"], dtype=float) for c in sorted({p[0] for p in pairs})]
    spheres = [np.array([_value(targets[s][k]) for k in "xyz"], dtype=float) for s in sorted({p[1] for p in pairs})]
    return n - _unseen_rotations(chucks) - _unseen_rotations(spheres)


def test_counts_agree_with_goswamis_formula(output, spec):
    _, numbers = output
    assert len(numbers["counts"]) >= 6
    for row in numbers["counts"]:
        assert row["parameters_scales"] == 54 and row["parameters_no_scales"] == 48  # Goswami: 7 links x 6 + 6 joints x 2
        for tag, scales in (("scales", True), ("no_scales", False)):
            assert row[f"armcal_{tag}"] == _oracle(spec, row["pairs"], scales), (row["case"], tag)


def test_counts_agree_with_goswamis_text(output):
    _, numbers = output
    every_chuck_and_sphere = [r for r in numbers["counts"] if r["chucks"] == 3 and r["spheres"] == 3]
    one_sphere = [r for r in numbers["counts"] if r["chucks"] == 3 and r["spheres"] == 1]
    assert any(len(r["pairs"]) == 9 for r in every_chuck_and_sphere) and any(len(r["pairs"]) == 6 for r in every_chuck_and_sphere)
    assert one_sphere
    for row in every_chuck_and_sphere:
        assert row["armcal_scales"] == 36
    for row in one_sphere:
        assert row["armcal_scales"] == 33
    quoted = {(len(r["pairs"]), r["spheres"]): r["goswami"] for r in numbers["counts"] if r["goswami"] is not None}
    assert quoted == {(9, 3): 36, (6, 3): 36, (3, 1): 33}
    assert numbers["spec_choice"] == {"free": 36, "rank": 36, "redundant": []}  # Table II: 18 of 54 held fixed


def test_calibration_reaches_the_simulated_noise(output, spec):
    _, numbers = output
    fit = numbers["calibration"]
    sigma = spec["device"]["noise"] * TO_MM[spec["robot"]["units"]["length"]] * spec.get("simulate", {}).get("noise_factor", 1.0)
    assert fit["simulated"] and fit["status"] == "converged"
    assert fit["noise_sigma_mm"] == pytest.approx(sigma)
    for name in ("calibration", "validation"):
        assert abs(fit[name]["rms_mm"] / sigma - 1) < 0.15, (name, fit[name]["rms_mm"], sigma)
        assert fit[name]["rms_before_mm"] > 10 * sigma  # the design model is far off: the fit did the work
        assert 700 <= fit[name]["samples"] <= 900  # "Each set consisted of about 800 poses"


def test_goswamis_numbers_are_quoted_right(output):
    _, numbers = output
    assert numbers["calibration"]["calibration"]["goswami_mm"] == 0.084
    assert numbers["calibration"]["validation"]["goswami_mm"] == 0.110
    if SEED.exists():  # the paper's text beside the project
        text = SEED.read_text()
        assert "46 cm set of shells was found to be 0.084 mm" in text and "The residual error was only 0.110 mm" in text
        assert "only 33 parameters while measuring the distance of a single endpoint-mounted steel sphere" in text
        assert "any six of these nine pairings are sufficient" in text


def test_printed_table_shows_the_numbers(output):
    stdout, numbers = output
    lines = stdout.splitlines()
    for row in numbers["counts"]:
        line = next(line for line in lines if line.startswith(row["case"]))
        fields = line[len(row["case"]) :].replace("|", " ").split()
        goswami = "-" if row["goswami"] is None else str(row["goswami"])
        expected = [str(row["chucks"]), str(row["spheres"]), str(row["armcal_scales"]), str(row["formula_scales"]), goswami]
        assert fields[:5] == expected and fields[-2:] == [str(row["armcal_no_scales"]), str(row["formula_no_scales"])], line
    assert "check: every count agrees" in stdout


def test_a_wrong_count_fails_the_check(output, capsys):
    _, numbers = output
    loaded = importlib.util.spec_from_file_location("goswami_tutorial", SCRIPT)
    module = importlib.util.module_from_spec(loaded)
    loaded.loader.exec_module(module)
    rows = [dict(r) for r in numbers["counts"]]
    rows[-1]["armcal_no_scales"] += 1
    problems = module.show(rows, numbers["spec_choice"], numbers["calibration"])
    assert problems and "DISAGREEMENTS" in capsys.readouterr().out


def test_the_pages_spec_excerpts_are_the_shipped_spec(spec):
    """Every yaml block of docs/tutorials/goswami.md is, section by section, the example's spec."""
    page = (ROOT / "docs" / "tutorials" / "goswami.md").read_text()
    blocks = re.findall(r"^```yaml[^\n]*\n(.*?)^```", page, re.M | re.S)
    assert len(blocks) >= 4
    shown = set()
    for block in blocks:
        excerpt = YAML(typ="safe").load(block)
        for section, value in excerpt.items():
            assert spec[section] == value, section
            shown.add(section)
    assert {"robot", "device", "procedure", "validation", "simulate"} <= shown
