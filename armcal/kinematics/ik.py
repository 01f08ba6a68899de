"""Inverse kinematics by Newton-Raphson, Stone (5.4), for many goals at once.

q_{k+1} = q_k - J^+(q_k) delta_k, with delta the difference between the reached
and the desired frame in base coordinates and J its Jacobian with respect to q
from CasADi automatic differentiation. J^+ is a damped least-squares inverse,
stable near degenerate configurations (5.2's caveat). A goal is either a full
pose or a point with an approach axis (the frame's z axis), which leaves the
rotation about that axis free. The rotational part of delta is the difference
of the frame's axis columns: it vanishes only at the goal, whereas the usual
differential rotation 1/2 sum(axis x axis*) also vanishes at a half turn and can
lead Newton to a flipped frame.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import casadi as ca
import numpy as np

from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.mapped import Mapped
from armcal.support.compiled import compiled

DAMPING = 1e-6  # Levenberg damping of the Newton step, well below J^T J's scale near a solution
SAFE_HALVINGS = 12  # for solve(halvings=...): a step that does not reduce the error is halved up to this many times
TOL_POSITION, TOL_ROTATION, MAX_ITERATIONS = 1e-6, 1e-9, 40  # solve's defaults: mm, axis columns, Newton steps
SAME_ROOT = 1e-6  # rad or mm: two solutions of one goal closer than this in every joint are one root (solve_in_order)
MAX_BLOCK = 1024  # goals solve_in_order solves at once: bounds its arrays
GUESS_ITERATIONS = 6  # Newton steps of solve_in_order's guesses: one that needs more is far from its start


@dataclass(frozen=True)
class IKResult:
    q: np.ndarray  # (N, n)
    converged: np.ndarray  # (N,) position within tol_position and rotation within tol_rotation
    position_error: np.ndarray  # (N,) mm
    rotation_error: np.ndarray  # (N,) norm of the axis-column differences (~ rad for small errors)


def error_function(model: KinematicModel, frame: str | None = None, width: int = 12) -> ca.Function:
    """delta(q, p, goal) and d delta / d q; goal of ``width`` 12 [p*, x*, y*, z*] (pose), 6 [p*, z*] (point + axis) or
    3 [p*] (a point, any orientation). The solvers build it for each call (``compiled_error``); a caller that solves
    many times may build it once and pass it as ``error``."""
    q = ca.SX.sym("q", model.dof)
    p = ca.SX.sym("p", len(model.parameters))
    T = model.fk(q, p) if frame is None else model.targets[frame](q, p)
    goal = ca.SX.sym("goal", width)
    position = T[:3, 3] - goal[:3]
    axes = {12: ca.vertcat(T[:3, 0], T[:3, 1], T[:3, 2]), 6: T[:3, 2], 3: ca.SX(0, 1)}[width]
    delta = ca.vertcat(position, axes - goal[3:])
    return ca.Function("ik_error", [q, p, goal], [delta, ca.jacobian(delta, q)])


def compiled_error(model: KinematicModel, frame: str | None, width: int, error: ca.Function | None) -> ca.Function:
    """``error``, else ``error_function`` through support/compiled.py: in machine code once its library is built (bit
    for bit the virtual machine's numbers, about nine times as fast; one library per robot, frame and goal width, kept
    across runs, built once the solves' work pays for it)."""
    return error if error is not None else compiled([error_function(model, frame, width)])[0]


def solve(
    model: KinematicModel,
    goals: np.ndarray,
    q0: np.ndarray,
    frame: str | None = None,
    p: np.ndarray | None = None,
    tol_position: float = TOL_POSITION,
    tol_rotation: float = TOL_ROTATION,
    max_iterations: int = MAX_ITERATIONS,
    halvings: int = 0,
    error: ca.Function | None = None,
) -> IKResult:
    """Solve N goals (N, 12) poses [p, x-axis, y-axis, z-axis], (N, 6) [p, z-axis] or (N, 3) [p] from q0 (N, n) or (n,)."""
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    function = compiled_error(model, frame, goals.shape[1], error)
    return _newton(_evaluator(function), model.dof, goals, q0, model.parameter_vector(p), tol_position, tol_rotation, max_iterations, halvings)


def solve_in_order(model: KinematicModel, goals: np.ndarray, q0: np.ndarray, halvings: int = SAFE_HALVINGS,
                   error: ca.Function | None = None) -> IKResult:
    """Solve goals one after another, each from the solution of the goal before it, the first from q0 (n,): a warm start
    that keeps one branch along a path of close goals (the wrist does not flip). Stops before the first goal not solved
    within the joint limits from its predecessor's solution: the result holds the goals solved before it.

    The chain is solved a block of goals at a time: each goal of the block from the block's start (the last solution),
    a guess, and then each from the guess of the goal before it. Where that guess is its goal's chained solution
    (the same root, within SAME_ROOT), the second solve is the chain's; the goals up to the first guess that found
    another root are taken. The block doubles while every guess holds and shrinks to what held when one does not:
    down to one goal, the chain itself, where neighbouring goals lie far apart."""
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    function = _evaluator(compiled_error(model, None, goals.shape[1], error))
    p = model.parameters.nominal

    def newton(rows: slice, q: np.ndarray, iterations: int = MAX_ITERATIONS, steps_halved: int = halvings) -> IKResult:
        return _newton(function, model.dof, goals[rows], q, p, TOL_POSITION, TOL_ROTATION, iterations, steps_halved)

    solved, start, done, block = [], np.asarray(q0, dtype=float), 0, 1
    while done < len(goals):
        rows = slice(done, min(len(goals), done + block))
        guess = newton(rows, start, GUESS_ITERATIONS, 0)  # plain Newton steps: a guess that needs more is no guess
        size = 1 + int(np.argmin(np.append(guess.converged[1:], False)))  # up to the first guess that did not converge
        chained = newton(slice(done, done + size), np.vstack([start, guess.q[: size - 1]]))  # the first from its predecessor
        other_root = np.flatnonzero(~(np.max(np.abs(chained.q[:-1] - guess.q[: size - 1]), axis=1) < SAME_ROOT))  # NaN: another
        chain = size if not len(other_root) else int(other_root[0]) + 1  # goals solved from their predecessors' solutions
        failed = np.flatnonzero(~(chained.converged[:chain] & within_limits(model, chained.q[:chain])))
        taken = chain if not len(failed) else int(failed[0])
        solved.append(_rows(chained, slice(0, taken)))
        if taken < chain:
            break
        start, done = chained.q[taken - 1], done + taken
        block = min(MAX_BLOCK, 2 * block) if taken == block else max(2, taken)
    return _joined(_empty(model.dof), *solved)


def _rows(result: IKResult, rows: slice) -> IKResult:
    return IKResult(*(getattr(result, f.name)[rows] for f in fields(IKResult)))


def _joined(*results: IKResult) -> IKResult:
    return IKResult(*(np.concatenate([getattr(r, f.name) for r in results]) for f in fields(IKResult)))


def _empty(dof: int) -> IKResult:
    return IKResult(np.zeros((0, dof)), np.zeros(0, dtype=bool), np.zeros(0), np.zeros(0))


def _newton(function, dof: int, goals: np.ndarray, q0: np.ndarray, p: np.ndarray, tol_position: float, tol_rotation: float,
            max_iterations: int, halvings: int) -> IKResult:
    """Newton-Raphson (5.4) on the error ``function`` for goals (N, m) from q0 (N, n) or (n,)."""
    Q = np.array(np.broadcast_to(q0, (len(goals), dof)), dtype=float)
    delta, J = function(Q, p, goals)
    for _ in range(max_iterations):
        rows = np.flatnonzero(~_done(delta, tol_position, tol_rotation) & np.isfinite(delta).all(axis=1))
        if not len(rows):
            break
        JT = J[rows].transpose(0, 2, 1)
        rhs = np.einsum("nij,nj->ni", JT, delta[rows])[..., None]
        step = np.linalg.solve(JT @ J[rows] + DAMPING * np.eye(dof), rhs)[..., 0]  # (5.4)
        _backtracked_step(function, p, goals, Q, delta, J, rows, step, halvings)
    return IKResult(
        q=Q,
        converged=_done(delta, tol_position, tol_rotation),
        position_error=np.linalg.norm(delta[:, :3], axis=1),
        rotation_error=np.linalg.norm(delta[:, 3:], axis=1),
    )


def _backtracked_step(function, p, goals, Q, delta, J, rows, step, halvings: int) -> None:
    """Q[rows] -= step, halved up to ``halvings`` times where it would not reduce |delta| (a near-singular
    model, e.g. the pseudo-DH of near-parallel axes with d of kilometres (Table 6-3), can send a full
    step astray). Q, delta and J are updated in place; after the last halving the step is taken as it is."""
    error = (delta[rows] ** 2).sum(axis=1)
    for halving in range(halvings + 1):
        trial = Q[rows] - step
        trial_delta, trial_J = function(trial, p, goals[rows])
        take = ((trial_delta**2).sum(axis=1) < error) | (halving == halvings)
        taken = rows[take]
        Q[taken], delta[taken], J[taken] = trial[take], trial_delta[take], trial_J[take]
        rows, step, error = rows[~take], step[~take] / 2, error[~take]
        if not len(rows):
            return


def _evaluator(function: ca.Function):
    """(Q (N, n), p, goals (N, m)) -> delta (N, m) and its Jacobian (N, m, n): ``function`` (error_function) mapped."""
    mapped = Mapped(function, shared=(1,))

    def evaluate(Q: np.ndarray, p: np.ndarray, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        delta, jacobian = mapped(Q, p, goals)
        # In the memory order of Function.map's own outputs (delta (m, N), J (m, N, n)), viewed as (N, m) and
        # (N, m, n): numpy's reductions and matmul in _newton add in an order that follows the memory layout, and
        # another order changes the last bits, near a branch point the root reached, and so what simulate plans.
        delta = np.ascontiguousarray(delta[:, 0].T).T
        return delta, np.ascontiguousarray(jacobian.transpose(2, 0, 1)).transpose(1, 0, 2)

    return evaluate


def _done(delta: np.ndarray, tol_position: float, tol_rotation: float) -> np.ndarray:
    return (np.linalg.norm(delta[:, :3], axis=1) < tol_position) & (np.linalg.norm(delta[:, 3:], axis=1) < tol_rotation)


def pose_goals(T: np.ndarray) -> np.ndarray:
    """(N, 4, 4) desired frames -> (N, 12) goal rows [p, n, o, a]."""
    T = np.atleast_3d(T) if np.ndim(T) == 3 else np.asarray(T)[None]
    return np.concatenate([T[:, :3, 3], T[:, :3, 0], T[:, :3, 1], T[:, :3, 2]], axis=1)


def within_limits(model: KinematicModel, Q: np.ndarray) -> np.ndarray:
    """Which configurations (N, n) respect every joint limit."""
    return np.all((Q >= model.limits[:, 0]) & (Q <= model.limits[:, 1]), axis=1)


def jacobi(
    design: KinematicModel,
    signature: KinematicModel,
    targets: np.ndarray,
    q0: np.ndarray,
    p_design: np.ndarray | None = None,
    p_signature: np.ndarray | None = None,
    resolution: float = 1e-6,
    max_iterations: int = 50,
) -> IKResult:
    """Jacobi iterative inverse of a signature model, Stone (5.8).

    q_{k+1} = F_d^-1[F_d(q_k) F_s(q_k)^-1 T*], started at q_0 = F_d^-1(T*); F_d^-1 is
    the design model's inverse (Newton-Raphson on the design model, from q_k).
    Converged when every joint's change is below ``resolution`` (5.3).
    """
    targets = np.asarray(targets, dtype=float)
    Q = np.array(np.broadcast_to(q0, (len(targets), design.dof)), dtype=float)
    converged = np.zeros(len(targets), dtype=bool)
    for _ in range(max_iterations):
        Fd = design.tool_poses(Q, p_design)
        Fs = signature.tool_poses(Q, p_signature)
        moved = Fd @ np.linalg.inv(Fs) @ targets  # (5.8), (5.10): T^k = F_d(q^k) Delta^k
        Q_next = solve(design, pose_goals(moved), Q, p=p_design).q
        converged = np.all(np.abs(Q_next - Q) < resolution, axis=1)
        Q = Q_next
        if converged.all():
            break
    reached = signature.tool_poses(Q, p_signature)
    delta_p = np.linalg.norm(reached[:, :3, 3] - targets[:, :3, 3], axis=1)
    delta_r = np.linalg.norm((reached[:, :3, :3] - targets[:, :3, :3]).reshape(len(Q), 9), axis=1)
    return IKResult(Q, converged, delta_p, delta_r)


def solve_from_starts(
    model: KinematicModel,
    goals: np.ndarray,
    frame: str | None = None,
    p: np.ndarray | None = None,
    starts: int = 12,
    seed: int = 0,
    error: ca.Function | None = None,
) -> np.ndarray:
    """Configurations (M, n) reaching M goals within the joint limits; NaN rows where none does.

    Each goal is tried from the middle of the limits and ``starts`` random
    configurations; of the solutions within limits the one closest to the middle
    is kept, so that neighbouring goals share one arm configuration.
    """
    return solve_from_starts_why(model, goals, frame, p, starts, seed, error)[0]


UNSOLVED, OUTSIDE_LIMITS, SOLVED = 0, 1, 2  # solve_from_starts_why's outcomes per goal
HELD = 0.5  # solve_pointing_where_held: the share of point-and-axis goals an arm holding the axis reaches


def solve_pointing_where_held(model: KinematicModel, points: np.ndarray, axes: np.ndarray, frame: str, seed: int = 0
                              ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, ...]]]:
    """``solve_from_starts_why`` of goals (M, 6), a point and the frame's z axis at it. An arm that holds the axis at
    fewer than HELD of them (fewer than six axes, or a wrist that cannot turn the frame so) is sent to the points alone
    (M, 3) where it does not hold it."""
    Q, outcome, blocking = solve_from_starts_why(model, np.concatenate([points, axes], axis=1), frame=frame, seed=seed)
    unheld = np.flatnonzero(outcome == UNSOLVED)
    if len(unheld) <= (1.0 - HELD) * len(points):
        return Q, outcome, blocking
    Q[unheld], outcome[unheld], alone = solve_from_starts_why(model, points[unheld], frame=frame, seed=seed)
    for row, joints in zip(unheld, alone):
        blocking[row] = joints
    return Q, outcome, blocking


def solve_from_starts_why(
    model: KinematicModel,
    goals: np.ndarray,
    frame: str | None = None,
    p: np.ndarray | None = None,
    starts: int = 12,
    seed: int = 0,
    error: ca.Function | None = None,
) -> tuple[np.ndarray, np.ndarray, list[tuple[int, ...]]]:
    """``solve_from_starts`` and why a goal has no configuration: (Q (M, n), outcome (M,), blocking joints per goal).

    outcome: SOLVED, OUTSIDE_LIMITS (Newton-Raphson converged from some start, every solution leaves a
    joint limit) or UNSOLVED (no start converged); blocking: for OUTSIDE_LIMITS the 0-based joints whose
    limits block the goal (``blocking_joints``), else ().
    """
    goals = np.atleast_2d(goals)
    rng = np.random.default_rng(seed)
    low, high = model.limits[:, 0], model.limits[:, 1]
    middle = (low + high) / 2
    seeds = np.vstack([middle, rng.uniform(low, high, (starts, model.dof))])
    count = len(goals)
    result = solve(model, np.repeat(goals, len(seeds), axis=0), np.tile(seeds, (count, 1)), frame=frame, p=p, tol_position=1e-4, tol_rotation=1e-6, error=error)
    Q = wrap_into_limits(model, result.q)
    good = result.converged & within_limits(model, Q)
    distance = np.where(good, np.linalg.norm((Q - middle) / (high - low), axis=1), np.inf).reshape(count, len(seeds))
    chosen = Q.reshape(count, len(seeds), -1)[np.arange(count), distance.argmin(axis=1)]
    solved = np.isfinite(distance.min(axis=1))
    chosen[~solved] = np.nan
    converged = result.converged.reshape(count, len(seeds))
    outcome = np.where(solved, SOLVED, np.where(converged.any(axis=1), OUTSIDE_LIMITS, UNSOLVED))
    per_goal = Q.reshape(count, len(seeds), -1)
    blocking = [blocking_joints(model, per_goal[i][converged[i]]) if outcome[i] == OUTSIDE_LIMITS else () for i in range(count)]
    return chosen, outcome, blocking


def blocking_joints(model: KinematicModel, solutions: np.ndarray) -> tuple[int, ...]:
    """The 0-based joints whose limits block a goal, from its solutions (k, n) wrapped into the limits.

    The joints that every solution leaves; when no joint is common to all, those of the solution that leaves
    its limits least (each joint's distance outside its range, the shorter way round for a revolute joint, over
    the range's width). Which solutions Newton-Raphson finds from random starts varies with the last bits of
    the arithmetic; a joint every solution leaves does not.
    """
    low, high = model.limits[:, 0], model.limits[:, 1]
    outside = (solutions < low) | (solutions > high)
    common = np.all(outside, axis=0)
    if common.any():
        return tuple(int(j) for j in np.flatnonzero(common))
    above = solutions - high
    revolute = np.array([kind == "revolute" for kind in model.joint_types])
    above = np.where(revolute, np.minimum(above, low + 2 * np.pi - solutions), above)
    excess = np.where(outside, np.maximum(low - solutions, above), 0.0) / (high - low)
    return tuple(int(j) for j in np.flatnonzero(outside[np.argmin(excess.sum(axis=1))]))


def wrap_into_limits(model: KinematicModel, Q: np.ndarray) -> np.ndarray:
    """Revolute joint values shifted by whole turns into their limits where possible."""
    Q = Q.copy()
    for i, kind in enumerate(model.joint_types):
        if kind == "revolute":
            low = model.limits[i, 0]
            Q[:, i] = low + np.mod(Q[:, i] - low, 2 * np.pi)
    return Q
