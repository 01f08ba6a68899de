"""Inverse kinematics by Newton-Raphson, Stone (5.4), for many goals at once.

q_{k+1} = q_k - J^+(q_k) delta_k, with delta the differential translation and
rotation between the reached and the desired frame in base coordinates, and J
its Jacobian with respect to q from CasADi automatic differentiation. J^+ is a
damped least-squares inverse, which equals J^-1 for a square, regular J and
stays stable near degenerate configurations (5.2's caveat). A goal is either a
full pose (position and rotation) or a point with an approach axis (the
frame's z axis), which leaves the rotation about that axis free.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from armcal.kinematics.compiler import KinematicModel

DAMPING = 1e-6  # Levenberg damping of the Newton step, well below J^T J's scale near a solution


@dataclass(frozen=True)
class IKResult:
    q: np.ndarray  # (N, n)
    converged: np.ndarray  # (N,) position within tol_position and rotation within tol_rotation
    position_error: np.ndarray  # (N,) mm
    rotation_error: np.ndarray  # (N,) rad


def _error_function(model: KinematicModel, frame: str | None, full_pose: bool) -> ca.Function:
    """delta(q, p, goal) and d delta / d q; goal = [p*, x*, y*, z*] (pose) or [p*, z*] (point + axis)."""
    q = ca.SX.sym("q", model.dof)
    p = ca.SX.sym("p", len(model.parameters))
    T = model.fk(q, p) if frame is None else model.targets[frame](q, p)
    goal = ca.SX.sym("goal", 12 if full_pose else 6)
    position = T[:3, 3] - goal[:3]
    if full_pose:  # differential rotation 1/2 sum(axis x axis*), Luh-Walker-Paul
        rotation = 0.5 * sum(ca.cross(T[:3, i], goal[3 + 3 * i : 6 + 3 * i]) for i in range(3))
    else:
        rotation = ca.cross(T[:3, 2], goal[3:6])
    delta = ca.vertcat(position, rotation)
    return ca.Function("ik_error", [q, p, goal], [delta, ca.jacobian(delta, q)])


def solve(
    model: KinematicModel,
    goals: np.ndarray,
    q0: np.ndarray,
    frame: str | None = None,
    p: np.ndarray | None = None,
    tol_position: float = 1e-6,
    tol_rotation: float = 1e-9,
    max_iterations: int = 40,
) -> IKResult:
    """Solve N goals (N, 12) poses [p, x-axis, y-axis, z-axis] or (N, 6) [p, z-axis] from q0 (N, n) or (n,)."""
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    count = len(goals)
    Q = np.array(np.broadcast_to(q0, (count, model.dof)), dtype=float)
    function = _error_function(model, frame, goals.shape[1] == 12)
    p = model.parameter_vector(p)
    active = np.ones(count, dtype=bool)
    for iteration in range(max_iterations + 1):
        rows = np.flatnonzero(active)
        delta, J = _evaluate(function, Q[rows], p, goals[rows])
        active[rows] = ~_done(delta, tol_position, tol_rotation) & np.isfinite(delta).all(axis=1)
        keep = active[rows]
        if not keep.any() or iteration == max_iterations:
            break
        rows, delta, J = rows[keep], delta[keep], J[keep]
        JT = J.transpose(0, 2, 1)
        rhs = np.einsum("nij,nj->ni", JT, delta)[..., None]
        Q[rows] -= np.linalg.solve(JT @ J + DAMPING * np.eye(model.dof), rhs)[..., 0]  # (5.4)
    delta = _evaluate(function, Q, p, goals)[0]
    return IKResult(
        q=Q,
        converged=_done(delta, tol_position, tol_rotation),
        position_error=np.linalg.norm(delta[:, :3], axis=1),
        rotation_error=np.linalg.norm(delta[:, 3:], axis=1),
    )


def _evaluate(function: ca.Function, Q: np.ndarray, p: np.ndarray, goals: np.ndarray):
    """delta (N, 6) and its Jacobian (N, 6, n) for N configurations, one mapped call."""
    delta, jac = function.map(len(Q))(Q.T, p, goals.T)
    return np.array(delta).T, np.array(jac).reshape(6, len(Q), Q.shape[1]).transpose(1, 0, 2)


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
    delta_r = np.linalg.norm(0.5 * sum(np.cross(reached[:, :3, i], targets[:, :3, i]) for i in range(3)), axis=1)
    return IKResult(Q, converged, delta_p, delta_r)
