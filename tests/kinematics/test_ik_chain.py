"""ik.solve_in_order, which solves a chain of goals (each from the solution of the goal before it) a block at a time,
gives the chain that one Newton-Raphson solve per goal gives (Stone 5.4; the loop below, written here): the same goals
solved, the same roots. The goals are the PUMA 560's tool by Stone's closed form (tests/puma_closed_form.py), so the
solutions are also checked to reach them independently of armcal's chain."""

import numpy as np
from puma_closed_form import t6

from armcal.kinematics import ik

BASE_Z = 671.83  # mm: DH frame 0 above the PUMA's base (specs/puma560_dh.yaml)
SAME = 1e-8  # rad: one root found from two starts (the solver stops within 1e-9 of the axes; another root is degrees away)


def _goals(Q: np.ndarray) -> np.ndarray:
    T = t6(Q)
    T[:, 2, 3] += BASE_Z
    return ik.pose_goals(T)


def _one_at_a_time(model, goals: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """The chain goal by goal: each from the solution before, stopping before the first not solved within the limits."""
    solutions, q = [], q0
    for goal in goals:
        result = ik.solve(model, goal[None], q, halvings=ik.SAFE_HALVINGS)
        if not (result.converged[0] and ik.within_limits(model, result.q)[0]):
            break
        solutions.append(result.q[0])
        q = result.q[0]
    return np.array(solutions).reshape(-1, model.dof)


def _path(count: int) -> np.ndarray:
    """A smooth joint path (rad) through joint 5's zero, where the wrist's two branches meet."""
    t = np.linspace(0.0, 1.0, count)[:, None]
    return np.deg2rad([-20, -100, 50, 40, 30, 90] + t * [40, 20, 10, 120, -60, 40] + 10 * np.sin(6 * np.pi * t) * [1, 0, 1, 0, 0, 1])


def _check(model, Q: np.ndarray, q0: np.ndarray) -> int:
    goals = _goals(Q)
    blocks = ik.solve_in_order(model, goals, q0)
    reference = _one_at_a_time(model, goals, q0)
    assert len(blocks.q) == len(reference)
    np.testing.assert_allclose(blocks.q, reference, rtol=0, atol=SAME)
    reached = _goals(blocks.q)
    assert np.abs(reached[:, :3] - goals[: len(reached), :3]).max(initial=0.0) < 1e-6  # mm, the solver's tolerance
    return len(reference)


def test_a_long_path_is_solved_in_blocks_as_the_chain(puma_models):
    """600 close goals: the blocks grow past one goal, and the wrist's singularity makes guesses find other roots."""
    Q = _path(600)
    assert _check(puma_models["puma560_dh"], Q, Q[0] + 0.01) == len(Q)


def test_goals_far_apart_give_the_chain_up_to_its_first_failure(puma_models):
    """Goals 20 deg apart in each joint: guesses from a block's start find other roots or none, and the chain (so
    solve_in_order) stops before the first goal not solved within the limits from its predecessor, after the same goals."""
    model = puma_models["puma560_dh"]
    rng = np.random.default_rng(5)
    middle, half = model.limits.mean(axis=1), (model.limits[:, 1] - model.limits[:, 0]) / 2
    solved = []
    for _ in range(6):
        Q = np.cumsum(np.vstack([rng.uniform(middle - 0.3 * half, middle + 0.3 * half), rng.uniform(-1, 1, (29, 6)) * np.deg2rad(20)]), axis=0)
        solved.append(_check(model, Q, Q[0] + 0.01))
    assert min(solved) < 5 and max(solved) > 10  # chains that stop early and chains that go on: both cases seen


def test_a_path_then_a_jump_stops_where_the_chain_stops(puma_models):
    """A path, then goals of another path far away: the same goals solved as one at a time."""
    Q = _path(300)
    other = Q[::-1] * [-1, 1, 1, -1, 1, -1] + [0.0, 0.0, 0.0, 0.5, 0.0, 0.0]
    _check(puma_models["puma560_dh"], np.vstack([Q, other]), Q[0])
