"""armcal plan --region: poses in the robot's working region, the I-criterion's weight over them, the CLI.

Oracle of the region's poses: tests/independent_sim.py's numpy forward model (no armcal) puts their measured
point in the box and, at the task's orientation, turns the target frame as the region says. The study's
numbers (benchmarks/plan_in_region.py, docs/plan.md) are in tests/procedures/test_plan_region_study.py (slow).
"""

from __future__ import annotations

import json

import numpy as np
from conftest import ROOT
import pytest

import independent_sim as sim
from armcal.devices import device_model
from armcal.evaluate.plan_accuracy import PlanStudy
from armcal.evaluate.working_region import working_region
from armcal.kinematics.compiler import compile_robot
from armcal.procedures.regions import region_candidates
from armcal.spec import load_spec
from test_plan import _cli, kuka  # noqa: F401 (a fixture)



@pytest.fixture(scope="module")
def puma(tmp_path_factory):
    path = tmp_path_factory.mktemp("puma") / "spec.yaml"
    path.write_text(sim.spec_text("puma560", "tracker"))
    return load_spec(path)


def _independent_target(Q: np.ndarray) -> np.ndarray:
    """The smr's frames (N, 4, 4) in the robot base frame, nominal geometry, from the independent model."""
    rows = [(t * sim.DEG, d, a, al * sim.DEG, 0.0) for t, d, a, al in sim.ROBOTS["puma560"]["dh"]]
    F6 = sim.frames({"rows": rows}, Q)[-1]
    offset = np.eye(4)
    offset[:3, 3] = sim.TRACKER["target"]
    return F6 @ offset


@pytest.mark.parametrize("oriented", [False, True])
def test_region_poses_put_the_measured_point_in_the_box(puma, oriented):
    kinematics, device = compile_robot(puma.spec.robot.chain()), device_model(puma.spec)
    region = working_region(puma.spec, kinematics, "iso_cube", oriented)
    side = region.high - region.low
    assert region.frame == "smr" and np.allclose(side, side[0]) and side[0] > 100.0  # a cube, of a useful size
    poses = region_candidates(puma.spec, kinematics, device, region, 40, seed=4)
    assert len(poses) == 40 and np.all(kinematics.limits[:, 0] <= poses.q) and np.all(poses.q <= kinematics.limits[:, 1])
    target = _independent_target(poses.q)
    assert np.all(target[:, :3, 3] >= region.low - 1e-3) and np.all(target[:, :3, 3] <= region.high + 1e-3)
    turns = np.linalg.norm(target[:, :3, :3] - region.rotation, axis=(1, 2))
    if oriented:
        assert turns.max() < 1e-5
    else:  # any orientation: spread over many
        assert np.median(turns) > 0.5 and np.ptp(target[:, :3, 3], axis=0).min() > 0.5 * side[0]


def test_the_region_weight_plans_for_the_region(puma):
    """With W over the region's poses (task orientation), the I-plan's linearised held-out error there is below the
    region-blind D-plan's and every random design's of as many poses; random poses in the region at any
    orientation are identifiable designs, the study's baseline (b)."""
    kinematics = compile_robot(puma.spec.robot.chain())
    region = working_region(puma.spec, kinematics, "iso_cube", oriented=True)
    study = PlanStudy(puma.spec, puma.path.parent, 400, seed=2, criterion="I", region=region, region_pool=300)
    whole = study.information.prediction_weight()
    assert not np.allclose(study.weight, whole, rtol=0.2)  # the region's W is not the whole joint range's
    planned = study.linearised(study.planned(15, "I").rows)
    assert planned < study.linearised(study.planned(15, "D").rows)
    random = [study.linearised(study.random(15, r)) for r in range(8)]
    in_region = [study.linearised(study.random_in_region(15, r)) for r in range(8)]
    assert planned < min(random) and planned < min(in_region) and np.isfinite(in_region).all()
    rows = study.random_in_region(15, 0)
    assert (rows >= len(study.candidates)).all() and len(set(rows)) == 15


def test_cli_plans_for_the_iso_cube(kuka, tmp_path):
    out = tmp_path / "cube.csv"
    result = _cli(kuka["tracker"], "--poses", 15, "--candidates", 300, "--runs", 1, "--region", "iso_cube", "--orientation", "any",
                  "--out", out, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    summary = json.loads(out.with_suffix(".json").read_text())
    assert summary["criterion"].startswith("I-optimal") and summary["region"]["name"] == "iso_cube"
    assert summary["region"]["orientation"] == "any the joints allow" and summary["region"]["point"] == "reflector"
    held = summary["held_out_accuracy"]
    assert held["random_in_region_same_count"]["mean"] > 0 and held["planned"]["mean"] > 0
    assert "working region: iso_cube" in result.stdout and "in the region (any orientation)" in result.stdout
    assert "held-out poses in the working region (iso_cube, any orientation)" in result.stdout
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape == (15, 6)


@pytest.mark.parametrize("device, args, message", [
    ("tracker", ["--region", "moon"], "--region moon: choose one of iso_cube, grid"),
    ("tracker", ["--region", "grid", "--orientation", "up"], "--orientation up"),
    ("ballbar", ["--region", "grid"], "reads each pose on its own pivot and sphere"),
])
def test_cli_region_mistakes_are_one_clear_message(kuka, tmp_path, device, args, message):
    result = _cli(kuka[device], "--poses", 5, *args, "--runs", 0, "--out", tmp_path / "p.csv", cwd=tmp_path)
    assert result.returncode == 1 and message in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "p.csv").exists()
