"""Stone's Monte-Carlo study (7.2-7.4): trends of the grid-index spreads along sweeps, backends, sweeps.

Oracles: the trends Stone found (7.4.1 linear in sigma_e, 7.4.3 linear in the noise
factor k, 7.4.4 1/sqrt(N_i)) and the plane-of-rotation accuracy (6.12), which
falls as 1/R. Tolerances: robot i is the same robot at every point of a sweep
(common random numbers), so the noise and sigma_e slopes differ from 1 only by
what is not proportional in the model (0.01 cm quantisation of the readings;
the fixed sigma_p, sigma_o beside sigma_e): 0.1 and 0.15. A new N_i draws new
readings, so that slope also carries sampling error: a sample standard deviation
of 60 robots is uncertain by 1/sqrt(2 x 59) = 9 %, a log-slope between N_i = 20
and 80 by sqrt(2) 0.09 / ln 4 = 0.09 per index; the median over 34 indices is
held to 0.2 (two such errors).
"""

import json

import numpy as np
import pytest
from conftest import ROOT, armcal_cli

from armcal.evaluate.sweeps import parse_sweep, variant
from armcal.kinematics.compiler import compile_robot
from armcal.commands.montecarlo import montecarlo
from armcal.spec import load_spec

SONIC = ROOT / "examples" / "puma560_sonic" / "spec.yaml"
RUNS = 60


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """One study per sweep, computed once for the module."""
    cache = {}

    def run(sweep: str | None, runs: int = RUNS, **options):
        key = (sweep, runs, tuple(sorted(options.items())))
        if key not in cache:
            out = tmp_path_factory.mktemp("montecarlo")
            cache[key] = montecarlo(SONIC, runs, [sweep] if sweep else [], out_dir=out, **options)
        return cache[key]

    return run


def test_noise_factor_scales_the_calibrated_spread_linearly(study):
    trend = study("noise_factor=1,10").summary["trend"]
    assert trend["controller"] == "calibrated"
    assert trend["median_slope"] == pytest.approx(1.0, abs=0.1)
    assert trend["radial_slope"] == pytest.approx(1.0, abs=0.1)


def test_more_points_per_circle_shrink_the_spread_as_one_over_root_n(study):
    trend = study("points_per_joint=20,80").summary["trend"]
    assert trend["median_slope"] == pytest.approx(-0.5, abs=0.2)


def test_encoder_errors_drive_the_design_controllers_spread_linearly(study):
    summary = study("sigma_e=0.1,0.5").summary
    assert summary["trend"]["controller"] == "design"
    assert summary["trend"]["median_slope"] == pytest.approx(1.0, abs=0.15)
    calibrated = [[row["calibrated"]["std"] for row in point["indices"]] for point in summary["points"]]
    assert np.allclose(calibrated[0], calibrated[1], rtol=0.5)  # the identified model does not care (7.2.3)


def test_a_larger_target_radius_sharpens_the_orientation_indices(study):
    """(6.12): plane-of-rotation accuracy ~ 1/R, so the orientation indices fall as 1/R; the lengths hang on
    the centres of rotation (6.13), which R does not change. Stone's 1/R^2 (7.4.5) is not reproduced here."""
    trend = study("target_radius=30,50").summary["trend"]
    assert trend["orientation_slope"] == pytest.approx(-1.0, abs=0.3)
    assert trend["length_slope"] > trend["orientation_slope"] + 0.4


def test_calibrated_control_beats_design_control_on_every_position_index(study):
    summary = study(None).summary
    point = summary["points"][0]
    assert point["converged"] == RUNS
    assert summary["grid"]["scaled"] is False and summary["grid"]["centre"] == [0.0, 55.0, 55.0]  # Stone's Table 7-1, as he ran it
    for row in point["indices"]:
        if row["index"].endswith("radial"):
            assert row["calibrated"]["std"] < row["design"]["std"] / 2, row["index"]


def test_the_backends_and_the_chunking_give_the_same_robots(study, tmp_path):
    serial = montecarlo(SONIC, 6, ["noise_factor=1,2"], out_dir=tmp_path / "serial", workers=1).summary
    pooled = study("noise_factor=1,2", runs=6, workers=2).summary
    assert serial["points"] == pooled["points"]


def test_files_of_a_study(study):
    result = study("noise_factor=1,10")
    names = {path.name for path in result.files}
    assert names == {"montecarlo.json", "montecarlo.csv", "montecarlo_spread.svg", "montecarlo_trend.svg"}
    assert json.loads((result.out_dir / "montecarlo.json").read_text())["runs"] == RUNS
    rows = (result.out_dir / "montecarlo.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * RUNS * 2 and rows[0].split(",")[4] == "line 1 length"


def test_target_radius_sweep_moves_every_swept_target_to_r():
    loaded = load_spec(SONIC)
    spec = variant(loaded.spec, "target_radius", parse_sweep("target_radius=30,50", loaded.spec).values[1])
    model = compile_robot(spec.robot.chain())
    q = np.asarray(spec.procedure.signature)
    frames = model.link_frames(q)
    for joint, name in enumerate(spec.procedure.targets, start=1):
        offset = model.target_poses(name, q[None])[0, :3, 3] - frames[joint - 1][:3, 3]
        axis = frames[joint - 1][:3, 2]
        assert np.linalg.norm(offset - (offset @ axis) * axis) == pytest.approx(500.0, abs=1e-9)  # 50 cm


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--sweep", "speed=1,2"], "unknown variable 'speed'"),
        (["--sweep", "noise_factor=1"], "at least two values"),
        (["--sweep", "points_per_joint=20,2.5"], "positive whole number"),
        (["--sweep", "points_per_joint=2,20"], "at least 3"),
        (["--sweep", "points_per_joint=inf,20"], "positive whole number"),
        (["--sweep", "noise_factor=2,2"], "repeats a value"),
        (["--sweep", "target_radius=30 cm,300 mm"], "repeats a value"),
        (["--seed", "-1"], "--seed"),
        (["--runs", "1"], "--runs"),
    ],
)
def test_study_mistakes_are_user_errors(tmp_path, arguments, message):
    result = armcal_cli("montecarlo", SONIC, "--out", tmp_path, *arguments)
    assert result.returncode in (1, 2) and message in result.stderr and "Traceback" not in result.stderr


def test_circle_point_sweeps_need_a_circle_point_procedure(tmp_path):
    from armcal.support.errors import UserError

    with pytest.raises(UserError, match="circle-point"):
        montecarlo(ROOT / "examples" / "goswami_ballbar" / "spec.yaml", 4, ["points_per_joint=20,40"], out_dir=tmp_path)


def test_a_least_squares_study_with_the_specs_declared_effects(tmp_path):
    """A spec fitted by Levenberg-Marquardt: every robot converges and calibrated control beats design control."""
    study = montecarlo(ROOT / "examples" / "goswami_ballbar" / "spec.yaml", 3, out_dir=tmp_path, workers=1).summary
    point = study["points"][0]
    assert study["method"] == "least_squares" and point["converged"] == 3
    radial = [row for row in point["indices"] if row["index"].endswith("radial")]
    assert all(row["calibrated"]["std"] < row["design"]["std"] for row in radial)


def test_an_output_path_that_is_a_file_is_a_user_error(tmp_path):
    from armcal.support.errors import UserError

    (tmp_path / "taken").write_text("")
    with pytest.raises(UserError, match="is a file"):
        montecarlo(SONIC, 2, out_dir=tmp_path / "taken" / "study")


def test_an_earlier_study_is_replaced_only_with_force_and_then_whole(tmp_path):
    """The output folder follows `armcal run`'s rule (issue 30 class 3): without --force an earlier study stays as it
    was; with it the new study replaces the folder's set whole (no trend plot of the earlier sweep survives); a
    folder holding anything else is never taken over."""
    from armcal.support.errors import UserError

    out = tmp_path / "study"
    montecarlo(SONIC, 2, ["noise_factor=1,2"], out_dir=out, workers=1)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert "montecarlo_trend.svg" in before
    with pytest.raises(UserError, match="montecarlo.json exists; use --force"):
        montecarlo(SONIC, 2, out_dir=out, workers=1)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    again = montecarlo(SONIC, 2, out_dir=out, workers=1, force=True)
    assert {p.name for p in out.iterdir()} == {p.name for p in again.files} | {".armcal-set.json"}
    assert "montecarlo_trend.svg" not in {p.name for p in out.iterdir()}
    other = tmp_path / "notes"
    other.mkdir()
    (other / "notes.txt").write_text("mine\n")
    with pytest.raises(UserError, match="not an armcal output set"):
        montecarlo(SONIC, 2, out_dir=other, workers=1, force=True)
    assert [p.name for p in other.iterdir()] == ["notes.txt"]


def test_a_study_folder_written_before_manifests_is_replaced_with_force(tmp_path):
    from armcal.support.errors import UserError

    out = tmp_path / "legacy"
    out.mkdir()
    for name in ("montecarlo.json", "montecarlo.csv", "plan_accuracy.svg"):
        (out / name).write_text("earlier\n")
    with pytest.raises(UserError, match="use --force"):
        montecarlo(SONIC, 2, out_dir=out, workers=1)
    montecarlo(SONIC, 2, out_dir=out, workers=1, force=True)
    assert not (out / "plan_accuracy.svg").exists() and (out / "montecarlo.json").read_text() != "earlier\n"
