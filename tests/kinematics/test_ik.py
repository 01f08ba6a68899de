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


def test_the_joints_blocking_a_goal_are_those_every_solution_leaves_else_the_least_excess():
    """ik.blocking_joints: a joint every solution leaves is named whatever other joints some solutions leave;
    without one, the solution leaving its limits least names its joints (a revolute joint measured the short way)."""
    from types import SimpleNamespace

    from armcal.kinematics.ik import blocking_joints

    deg = np.radians
    model = SimpleNamespace(limits=deg(np.array([[-30.0, 30.0], [-180.0, 0.0], [40.0, 160.0]])), joint_types=("revolute",) * 3)
    common = deg(np.array([[100.0, -90.0, 300.0], [200.0, 10.0, 90.0]]))  # j1 out in both, j2 and j3 in one each
    assert blocking_joints(model, common) == (0,)
    # no joint common: [j2 10 deg above 0, of a 180 deg range] against [j3 at 300 deg, 100 deg short of 40 the short
    # way round (not 140 above 160), of 120] and [j3 at 165, 5 of 120]: the last leaves least, then the first
    mixed = deg(np.array([[0.0, 10.0, 90.0], [0.0, -90.0, 300.0], [0.0, -90.0, 165.0]]))
    assert blocking_joints(model, mixed) == (2,) and blocking_joints(model, mixed[:2]) == (1,)
    wrapped = deg(np.array([[0.0, 20.0, 90.0], [0.0, -90.0, 395.0]]))  # j3 at 395 = 35 deg: 5 deg below 40 the short way
    assert blocking_joints(model, wrapped) == (2,)


def _casadis_own_map(function):
    """The evaluator before Mapped: one Function.map call, its outputs viewed as they come (the oracle)."""

    def evaluate(Q, p, goals):
        delta, jacobian = function.map(len(Q))(Q.T, p, goals.T)
        return np.array(delta).T, np.array(jacobian).reshape(goals.shape[1], len(Q), Q.shape[1]).transpose(1, 0, 2)

    return evaluate


def test_solutions_are_bitwise_those_of_casadis_own_map(puma_models):
    """Speed may not change a root: Newton from far starts (many reach other branches, some halve their steps)
    gives the same bits through Mapped as through Function.map, whose memory order numpy's sums follow."""
    model = puma_models["puma560_dh"]
    truth = random_configurations(model, 400, seed=11)
    goals = ik.pose_goals(model.tool_poses(truth))
    start = truth + np.random.default_rng(12).normal(scale=0.8, size=truth.shape)
    function, p = ik.error_function(model), model.parameter_vector(None)
    for halvings in (0, ik.SAFE_HALVINGS):
        got = ik._newton(ik._evaluator(function), model.dof, goals, start, p, ik.TOL_POSITION, ik.TOL_ROTATION,
                         ik.MAX_ITERATIONS, halvings)
        expected = ik._newton(_casadis_own_map(function), model.dof, goals, start, p, ik.TOL_POSITION, ik.TOL_ROTATION,
                              ik.MAX_ITERATIONS, halvings)
        other_root = np.abs(np.angle(np.exp(1j * (expected.q - truth)))).max(axis=1) > 1e-3
        assert other_root.mean() > 0.2  # far starts: many goals are reached on another branch than the truth's
        np.testing.assert_array_equal(got.q, expected.q)
