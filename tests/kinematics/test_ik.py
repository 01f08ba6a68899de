"""Newton-Raphson inverse kinematics (Stone 5.4) recovers configurations whose poses are known."""

import numpy as np
from conftest import random_configurations

from armcal.kinematics import ik


def test_full_pose_goals_are_reached_from_a_nearby_start(puma_models):
    model = puma_models["puma560_dh"]
    truth = random_configurations(model, 300, seed=7)
    goals = ik.pose_goals(model.tool_poses(truth))
    start = truth + np.random.default_rng(8).normal(scale=0.05, size=truth.shape)  # ~3 deg off, as from a design model
    result = ik.solve(model, goals, start)
    reached = model.tool_poses(result.q)
    assert result.converged.mean() > 0.98
    ok = result.converged
    assert np.abs(reached[ok] - model.tool_poses(truth)[ok]).max() < 1e-5


def test_point_and_axis_goal_of_a_target(puma_models):
    model = puma_models["puma560_six"]
    truth = random_configurations(model, 100, seed=9)
    T = model.target_poses("reflector", truth)
    goals = np.concatenate([T[:, :3, 3], T[:, :3, 2]], axis=1)
    result = ik.solve(model, goals, truth + 0.03, frame="reflector")
    got = model.target_poses("reflector", result.q)
    ok = result.converged
    assert ok.mean() > 0.95
    assert np.abs(got[ok][:, :3, 3] - T[ok][:, :3, 3]).max() < 1e-5
    assert np.abs(got[ok][:, :3, 2] - T[ok][:, :3, 2]).max() < 1e-6
