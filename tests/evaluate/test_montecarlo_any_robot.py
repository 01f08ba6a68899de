"""`armcal montecarlo` for any robot and device (issue 17, item 3): the grid stands at Table 7-1 where the design
model reaches it (the PUMA: Stone's own study, tests/evaluate/test_montecarlo.py), else where `armcal run` places it.

Oracles from outside the study: the design model's forward kinematics at the study's design-control joints give the
grid's frames (1e-4 mm, the inverse kinematics' tolerance) within the joint limits; Table 7-1's box is centred at
(0, 55, 55) cm; data that identify the robot leave smaller errors than the design model under calibrated control; the
same seed gives the same robots. Which absolute orientation indices a device's data cannot calibrate follows from
what it observes on the tool centre point's link (evaluate/grid.unobserved_orientation's docstring).
"""

import numpy as np
import pytest
from conftest import ROOT
from test_task_placement import SCARA

from armcal.support.errors import UserError
from armcal.evaluate.grid import ORIENTATION, RADIAL, unobserved_orientation
from armcal.evaluate.montecarlo import RobotStudy
from armcal.commands.montecarlo import montecarlo
from armcal.spec import load_spec

HIDDEN_HARMONIC = ROOT / "examples" / "hidden_harmonic" / "spec.yaml"
UR10 = ROOT / "specs" / "ur10.yaml"


@pytest.fixture(scope="module")
def scara(tmp_path_factory):
    spec = tmp_path_factory.mktemp("scara") / "spec.yaml"
    spec.write_text(SCARA)
    return spec


def _means(summary: dict, controller: str, names) -> np.ndarray:
    rows = {row["index"]: row for row in summary["points"][0]["indices"]}
    return np.array([abs(rows[name][controller]["mean"]) for name in names])


def test_a_scara_gets_the_grid_placed_in_its_workspace_and_reached(scara, tmp_path):
    summary = montecarlo(scara, 4, out_dir=tmp_path / "a", workers=1).summary
    grid = summary["grid"]
    assert grid["scaled"] and grid["unit"] == "mm" and "placed by armcal" in grid["placement"]
    stroke = 200.0  # the quill's travel (j3) bounds the grid's height, 500 mm at Table 7-1's size, grown 10 % for the margin
    assert 0.9 * stroke / (1.1 * 500) <= grid["scale"] <= stroke / (1.1 * 500)
    assert "judged on position" in grid["placement"]  # four axes: the tool's axis is held, not its turn about it
    loaded = load_spec(scara)
    study = RobotStudy(loaded.spec, loaded.path.parent)  # the study's own design-control solution, checked by forward kinematics
    chain, control = study.simulator.kinematics, study.control
    limits = chain.limits
    assert ((control.q_design >= limits[:, 0] - 1e-9) & (control.q_design <= limits[:, 1] + 1e-9)).all()
    np.testing.assert_allclose(chain.target_poses("reflector", control.q_design), control.desired, atol=1e-4)
    vertices = control.desired[:, :3, 3]
    np.testing.assert_allclose((vertices.min(axis=0) + vertices.max(axis=0)) / 2, grid["centre"], atol=1e-5)
    np.testing.assert_allclose(np.ptp(vertices, axis=0), grid["scale"] * np.array([600.0, 300.0, 500.0]), rtol=1e-9)
    assert summary["points"][0]["converged"] == 4
    assert (_means(summary, "calibrated", RADIAL) < _means(summary, "design", RADIAL) / 3).all()
    orientation = [row["index"] for row in summary["points"][0]["indices"] if "orientation" in row["index"]]
    assert summary["unobserved"]["indices"] == orientation and len(orientation) == 7  # 4 absolute, 3 relative: not commanded
    assert "judged on position" in summary["unobserved"]["reason"]
    again = montecarlo(scara, 4, out_dir=tmp_path / "b", workers=1).summary
    assert again["points"] == summary["points"]  # the same seed, the same robots


def test_hidden_harmonic_keeps_table_7_1_and_calibration_wins(tmp_path):
    """A PUMA (six-parameter convention, base 67 cm up) reaches Table 7-1: its grid stays Stone's."""
    summary = montecarlo(HIDDEN_HARMONIC, 4, out_dir=tmp_path, workers=1).summary
    assert summary["grid"]["scaled"] is False and summary["grid"]["scale"] == 1.0
    assert summary["grid"]["centre"] == [0.0, 55.0, 55.0] and summary["grid"]["unit"] == "cm"
    assert (_means(summary, "calibrated", RADIAL) < _means(summary, "design", RADIAL) / 3).all()
    assert summary["unobserved"] is not None  # one reflector, no orientation


def test_ur10_with_a_6dof_probe_calibrates_every_index(tmp_path):
    """The UR10 spec's tracker reads the probe's orientation: the absolute orientation indices are calibrated too."""
    summary = montecarlo(UR10, 2, out_dir=tmp_path, workers=1).summary
    assert summary["unobserved"] is None and summary["points"][0]["converged"] == 2
    for names in (RADIAL, ORIENTATION):
        assert (_means(summary, "calibrated", names) < _means(summary, "design", names) / 10).all()


def test_a_robot_that_reaches_no_grid_is_told_so(scara, tmp_path):
    tiny = tmp_path / "spec.yaml"  # shoulder and elbow that turn 2 deg: no grid fits its workspace
    tiny.write_text(SCARA.replace("limits: [-132, 132]", "limits: [0, 2]").replace("limits: [-141, 141]", "limits: [0, 2]"))
    with pytest.raises(UserError, match=r"neither at Table 7-1 nor, scaled, .*: with a horizontal reach of \d+ mm, no Stone's grid down to .* is reached"):
        montecarlo(tiny, 2, out_dir=tmp_path / "out", workers=1)


@pytest.mark.parametrize(
    "spec, observed",
    [
        (UR10, True),  # a 6-DOF probe
        (ROOT / "examples" / "goswami_ballbar" / "spec.yaml", True),  # three spheres on link 6
        (HIDDEN_HARMONIC, False),  # one reflector
        (ROOT / "examples" / "theodolite" / "spec.yaml", False),  # one ball
        (ROOT / "examples" / "puma560_sonic" / "spec.yaml", False),  # one sparker on link 6
    ],
)
def test_which_devices_observe_the_tools_orientation(spec, observed):
    assert (unobserved_orientation(load_spec(spec).spec) is None) is observed


def test_the_study_predicts_held_out_accuracy_against_the_number_of_poses(tmp_path):
    """--poses: N planned (D-optimal) and N, 3N random calibration poses scored on the study's robots; the figure of
    one design recomputed robot by robot with the plan study (evaluate/plan_accuracy.py) from the same seeds; three
    times the random poses leave a smaller error (noise averaged over 3x the readings); the plot is written."""
    from armcal.evaluate.montecarlo import robot_seeds
    from armcal.evaluate.plan_accuracy import PlanStudy
    from armcal.commands.plan import DEFAULT_CANDIDATES

    study = montecarlo(UR10, 3, out_dir=tmp_path / "a", workers=1, seed=5, poses=[15])
    curve = study.summary["accuracy_vs_poses"]
    assert curve["unit"] == "mm" and curve["counts"] == [15] and "held-out" in curve["definition"]
    planned, random_n, random_3n = curve["planned"]["D"][0], curve["random"]["1"][0], curve["random"]["3"][0]
    assert random_3n < random_n
    plan = PlanStudy(load_spec(UR10).spec, UR10.parent.resolve(), DEFAULT_CANDIDATES, 5)
    rows = plan.planned(15).rows
    again = np.mean([plan.accuracy(rows, seed) for seed in robot_seeds(5, 3)])
    assert planned == pytest.approx(again, rel=1e-9)
    assert (tmp_path / "a" / "plan_accuracy.svg").read_text().lstrip().startswith("<?xml")


def test_a_poses_list_that_is_not_numbers_is_a_user_error():
    from armcal.commands.montecarlo import pose_counts

    assert pose_counts("30,15,30") == [15, 30]
    for bad in ("15;30", "0,15", "a"):
        with pytest.raises(UserError, match="--poses"):
            pose_counts(bad)


def test_too_few_poses_for_any_design_are_refused_before_the_study(tmp_path):
    """--poses 4 on the UR10 (6 readings a pose, 30 base parameters): no design of 4 poses can be identified, so the
    study says so at once, exit 1, and writes nothing (issue 30 leftover 6)."""
    from conftest import armcal_cli

    with pytest.raises(UserError, match=r"--poses 4,20: 4 poses give at most 24 readings .* 30 base parameters.*at least 5"):
        montecarlo(UR10, 2, out_dir=tmp_path / "a", workers=1, seed=5, poses=[4, 20])
    assert not (tmp_path / "a").exists()
    result = armcal_cli("montecarlo", UR10, "--runs", 2, "--poses", 2, "--workers", 1, "--out", tmp_path / "b")
    assert result.returncode == 1 and "Traceback" not in result.stderr and "cannot determine" in result.stderr, result.stderr
    assert not (tmp_path / "b").exists()


def test_a_curve_no_design_identified_is_drawn_as_a_note():
    from armcal.report.plan_plots import accuracy_plot

    drawn = accuracy_plot({"counts": [6, 7], "planned": {"D": [None, None]}, "random": {"1": [None, None], "3": [None, None]}})
    assert drawn.lstrip().startswith("<?xml") and "identified" in drawn
    partial = accuracy_plot({"counts": [6, 30], "planned": {"D": [None, 0.05]}, "random": {"1": [None, 0.08], "3": [None, None]}})
    assert "random N" in partial
