"""armcal compare on two real calibrations of one simulated robot (tests/independent_sim.py, not armcal's
simulator): the same PUMA measured twice by a tracker, the upper arm (j2.a) 5 combined standard uncertainties
longer in the second campaign, other poses and other noise. Only j2.a is flagged, from the run folders, from the
calibrated specs (whose std equals results.json's) and from one calibrated spec at two git revisions."""

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import armcal_cli
from independent_sim import COUNTS, TRACKER, readings, sample_configurations, spec_text, true_geometry, write_csv

from armcal.commands.run import run

ROBOT, DEVICE = "puma560", "tracker"


def _campaign(folder, geom, seed):
    """A clean tracker campaign of the robot ``geom`` with poses and noise from ``seed``."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    (folder / "spec.yaml").write_text(spec_text(ROBOT, DEVICE))
    for name, count in zip(("calibration.csv", "validation.csv"), COUNTS[DEVICE]):
        q = sample_configurations(ROBOT, count, rng)
        keys = [("smr",)] * count
        y = readings(geom, DEVICE, np.deg2rad(q), keys)
        write_csv(folder / name, DEVICE, q, keys, y + rng.normal(0, TRACKER["noise"], y.shape))
    run(folder / "spec.yaml", folder / "out", pdf=False)
    return folder / "out"


def _flagged(stdout: str) -> list[str]:
    """The parameters flagged (the first block; the predicted positions follow a blank line)."""
    return [line.split()[0] for line in stdout.split("\n\n")[0].splitlines() if line.endswith("significant")]


@pytest.fixture(scope="module")
def two_calibrations(tmp_path_factory):
    root = tmp_path_factory.mktemp("recalibration")
    geom, _ = true_geometry(ROBOT, DEVICE, np.random.default_rng(5))
    first = _campaign(root / "first", geom, seed=51)
    std = next(p["std"] for p in json.loads((first / "results.json").read_text())["parameters"] if p["name"] == "j2.a")
    theta, d, a, alpha, beta = geom["rows"][1]
    geom["rows"][1] = (theta, d, a + 5.0 * np.sqrt(2.0) * std, alpha, beta)  # 5 combined sigmas, mm
    second = _campaign(root / "second", geom, seed=52)
    return root, first, second


def test_the_changed_link_is_flagged_and_no_other(two_calibrations):
    _, first, second = two_calibrations
    result = armcal_cli("compare", first, second)
    assert result.returncode == 0, result.stderr
    assert _flagged(result.stdout) == ["j2.a"]
    z = float(next(line for line in result.stdout.splitlines() if line.startswith("j2.a")).split()[5])
    assert 3.0 < z < 7.0  # 5 expected, its own noise 1
    assert "1 significant change(s) among" in result.stdout


def test_calibrated_specs_carry_results_uncertainties_and_compare_alike(two_calibrations):
    _, first, second = two_calibrations
    from armcal.spec import load_spec

    results = {p["name"]: p for p in json.loads((first / "results.json").read_text())["parameters"]}
    robot = load_spec(first / "calibrated.yaml").spec.robot
    checked = 0
    for name, joint in zip(robot.joint_names(), robot.joints):
        for field, to_spec_unit in (("a", 1.0), ("alpha", np.rad2deg(1.0))):
            row = results[f"{name}.{field}"]
            if row["free"]:
                assert getattr(joint, field).std * to_spec_unit == pytest.approx(row["std"], rel=5e-3), f"{name}.{field}"
                checked += 1
    assert checked >= 8
    result = armcal_cli("compare", first / "calibrated.yaml", second / "calibrated.yaml")
    assert result.returncode == 0, result.stderr
    assert _flagged(result.stdout) == ["j2.a"]


@pytest.mark.skipif(shutil.which("git") is None, reason="git makes the test repository")
def test_a_calibrated_spec_at_two_git_revisions(two_calibrations):
    root, first, second = two_calibrations
    repo = root / "repo"
    repo.mkdir()
    git = lambda *args: subprocess.run(["git", "-C", repo, "-c", "user.name=t", "-c", "user.email=t@t", *args], check=True, capture_output=True)  # noqa: E731
    git("init", "-q")
    for out, message in ((first, "first calibration"), (second, "recalibration")):
        shutil.copy(out / "calibrated.yaml", repo / "robot.yaml")
        git("add", "robot.yaml")
        git("commit", "-q", "-m", message)
    git("tag", "-a", "v1", "-m", "first", "HEAD~1")
    spec = repo / "robot.yaml"
    for old in (f"{spec}@HEAD~1", f"{spec}@v1", f"{spec}@HEAD^"):
        result = armcal_cli("compare", old, spec)
        assert result.returncode == 0, result.stderr
        assert _flagged(result.stdout) == ["j2.a"], old
    git("gc", "-q")  # the same from packed objects and refs
    assert _flagged(armcal_cli("compare", f"{spec}@v1", f"{spec}@HEAD").stdout) == ["j2.a"]
    missing = armcal_cli("compare", f"{spec}@nosuchbranch", spec)
    assert missing.returncode == 1 and "no branch, tag or commit 'nosuchbranch'" in missing.stderr
    root_commit = armcal_cli("compare", f"{spec}@HEAD~2", spec)
    assert root_commit.returncode == 1 and "has 0 parent(s)" in root_commit.stderr


def test_two_robots_or_chains_under_one_serial_are_not_compared_and_nonsense_numbers_are_refused(tmp_path):
    """Identity is more than the serial (issue 30 class 4): another robot, or another chain, under the same serial (a
    placeholder) is refused; a results.json whose parameter std is NaN, infinite or negative is not read."""
    import json

    from armcal.support.errors import UserError
    from armcal.results.compare import compare

    golden = json.loads((Path(__file__).resolve().parents[1] / "data" / "golden" / "results.json").read_text())
    (tmp_path / "a.json").write_text(json.dumps(golden))
    for change, phrase in ((lambda r: r["robot"].update(name="Another arm"), "must be of one robot and one model"),
                           (lambda r: r["robot"].update(convention="mdh"), "must be of one robot and one model"),
                           (lambda r: r["robot"].update(dof=7), "must be of one robot and one model")):
        other = json.loads(json.dumps(golden))
        change(other)
        (tmp_path / "b.json").write_text(json.dumps(other))
        with pytest.raises(UserError, match=phrase):
            compare(str(tmp_path / "a.json"), str(tmp_path / "b.json"))
    text, significant = compare(str(tmp_path / "a.json"), str(tmp_path / "a.json"))
    assert significant == 0
    for bad in ("NaN", "Infinity", "-1.0"):
        raw = json.dumps(golden)
        row = next(p for p in golden["parameters"] if p["std"] is not None)
        broken = raw.replace(json.dumps(row), json.dumps({**row, "std": 12345.678}).replace("12345.678", bad), 1)
        assert broken != raw
        (tmp_path / "b.json").write_text(broken)
        with pytest.raises(UserError, match="not a results.json as armcal writes it"):
            compare(str(tmp_path / "a.json"), str(tmp_path / "b.json"))


@pytest.mark.parametrize("edit, phrase", [
    (lambda r: r["parameters"].append(dict(r["parameters"][-1])), "parameters listed twice"),
    (lambda r: r["parameters"].insert(0, {**r["parameters"][0], "name": f"j{r['robot']['dof'] + 2}.theta"}), "joints or links the robot"),
    (lambda r: r.update(correlation_matrix={"parameters": ["L1.x", "L1.y"], "matrix": [[1.0, 0.0]]}), "not square"),
    (lambda r: r["parameters"].insert(0, {**r["parameters"][0], "name": "j0.theta"}), "joints or links the robot"),
    (lambda r: (r["robot"].update(convention="six_parameter"), r["parameters"].insert(0, {**r["parameters"][0], "name": "L9.x"})), "L9.x"),
], ids=["twice", "joint-beyond-dof", "matrix-not-square", "joint-0", "six-parameter-link-beyond"])
def test_a_results_file_that_contradicts_itself_is_not_read(tmp_path, edit, phrase):
    """What no run writes (a parameter twice, a default-named joint or a six_parameter link the robot lacks, a ragged correlation matrix)
    is refused by compare and report with the file's name, exit 1, nothing printed of the file beyond the rule."""
    import json

    golden = json.loads((Path(__file__).resolve().parents[1] / "data" / "golden" / "results.json").read_text())
    (tmp_path / "a.json").write_text(json.dumps(golden))
    edit(golden)
    (tmp_path / "b.json").write_text(json.dumps(golden))
    done = armcal_cli("compare", tmp_path / "a.json", tmp_path / "b.json")
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert f"{tmp_path / 'b.json'}: not a results.json as armcal writes it" in done.stderr and phrase in done.stderr


def test_an_effect_held_as_nearly_redundant_names_its_partners():
    """identifiability.extend's reason for an effect parameter held as weakly identifiable names the base parameters
    that nearly absorb it: compare treats them as its partners, not comparable, like an exact redundancy's."""
    from armcal.results.changes import Basis

    reason = ("weakly identifiable: nearly redundant with joint_compliance.j3.my4, j3.a (new part 7.4e-05 of its "
              "column, below 0.001) at the design point")
    assert Basis({"joint_compliance.j3.my5": reason}).partners("joint_compliance.j3.my5") == {"joint_compliance.j3.my4", "j3.a"}
