"""Evaluation tasks in a robot's own workspace (issue 17, item 1): robots that are not the PUMA get Stone's grid and
the ISO 9283 cube placed by armcal, with no extra spec keys. Checked from outside the placement: every placed frame is
reached by the design model at joints whose forward kinematics equal it (1e-4 mm, the inverse kinematics' tolerance), P1..P5 lie on the reported cube's
diagonal plane at 10 % from its corners (ISO 9283), a cube 15 % larger at that centre is not reached, and calibrated
control beats design control on the simulated true robot."""

import itertools
import json

import numpy as np
import pytest
from conftest import armcal_cli

from armcal.kinematics import ik
from armcal.kinematics.compiler import compile_robot
from armcal.procedures.placement import MARGIN, POSE, Workspace, place_cube, place_grid
from armcal.spec import load_spec

# An Epson-like SCARA: two horizontal links, a prismatic quill, a wrist turn; the tool points down (alpha 180).
SCARA = """armcal: 1
data: {calibration: calibration.csv, validation: validation.csv}
simulate: {seed: 3}
robot:
  name: SCARA RRPR
  serial: SCARA-1
  units: {length: mm, angle: deg}
  convention: dh
  joints:
    - {name: j1, limits: [-132, 132], theta: 0, d: 400, a: 325, alpha: 0}
    - {name: j2, limits: [-141, 141], theta: 0, d: 0, a: 275, alpha: 180}
    - {name: j3, type: prismatic, limits: [0, 200], theta: 0, d: 0, a: 0, alpha: 0}
    - {name: j4, limits: [-360, 360], theta: 0, d: 50, a: 0, alpha: 0}
  targets:
    reflector: {link: 4, x: 40, y: 0, z: 30}
device:
  type: tracker
  targets: [reflector]
  robot_base: {x: 2500, y: 0, z: 0, rz: 180, ry: 0, rx: 0}
  noise: 0.02
procedure: {type: poses, count: 120, seed: 1}
validation: {type: poses, count: 60, seed: 2}
"""


def _new(tmp_path, robot, device):
    spec = tmp_path / "spec.yaml"
    result = armcal_cli("new", "--robot", robot, "--device", device, "--out", spec)
    assert result.returncode == 0, result.stderr
    return spec


def _scara(tmp_path, robot, device):  # noqa: ARG001 (the parametrisation's shape)
    spec = tmp_path / "spec.yaml"
    spec.write_text(SCARA)
    return spec


@pytest.mark.parametrize("make, robot, device", [(_new, "kuka_kr6_r900_sixx", "tracker"), (_scara, "scara", "tracker"), (_new, "kuka_kr6_r900_sixx", "ballbar")])
def test_tasks_are_placed_and_evaluated_without_extra_keys(tmp_path, make, robot, device):
    spec = make(tmp_path, robot, device)
    assert "report" not in load_spec(spec).spec.model_fields_set
    assert armcal_cli("simulate", spec, "--out", tmp_path).returncode == 0
    run = armcal_cli("run", spec, "--out", tmp_path / "out", "--no-pdf")
    assert run.returncode == 0, run.stderr + run.stdout
    assert "Grid-touching task (Stone 7.2.1): 34 indices" in run.stdout and "placed by armcal" in run.stdout
    assert "ISO 9283 positional accuracy (side" in run.stdout
    evaluation = json.loads((tmp_path / "out" / "results.json").read_text())["evaluation"]
    grid, iso = evaluation["grid_task"], evaluation["iso9283"]
    assert len(grid["indices"]) == 34 and len(iso["poses"]) == 5
    if device == "tracker":  # the tracker sees the tool centre point the tasks are commanded at
        assert np.median([r["improvement_factor"] for r in grid["indices"] if r["improvement_factor"] is not None]) > 2
        assert all(r["calibrated"] < r["design"] for r in iso["poses"])


@pytest.mark.parametrize("robot", ["kuka_kr6_r900_sixx", "abb_irb120", "ur5e"])
def test_placed_frames_are_reached_and_the_cube_is_the_largest(tmp_path, robot):
    spec = load_spec(_new(tmp_path, robot, "tracker")).spec
    chain = compile_robot(spec.robot.chain())
    space = Workspace(chain, chain.parameters.nominal, "reflector")
    for placed in (place_grid(space), place_cube(space)):
        assert placed is not None and placed.goal == POSE and "judged on position and orientation" in placed.how
        assert ik.within_limits(chain, placed.q).all()  # the search's joints: within the limits, reaching every frame
        np.testing.assert_allclose(chain.target_poses("reflector", placed.q), placed.frames, atol=1e-4)  # the inverse kinematics' own tolerance, mm
    cube = place_cube(space)
    c, side = cube.centre, cube.size
    corners = c + side / 2 * np.array([[-1, -1, -1], [1, 1, -1], [1, 1, 1], [-1, -1, 1]])
    np.testing.assert_allclose(cube.frames[0, :3, 3], c)
    np.testing.assert_allclose(cube.frames[1:, :3, 3], c + 0.8 * (corners - c))  # ISO 9283: 10 % of the diagonal in
    larger = np.repeat(cube.frames[:1], 8, axis=0)  # the corners of a cube 15 % larger than the margin's, oriented as the test poses
    larger[:, :3, 3] = c + 1.15 * (1 + MARGIN) * side / 2 * np.array(list(itertools.product((-1, 1), repeat=3)))
    assert np.isnan(ik.solve_from_starts(chain, ik.pose_goals(larger), frame="reflector", starts=48)).any()
