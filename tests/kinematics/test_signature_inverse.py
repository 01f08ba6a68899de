"""Newton-Raphson (5.4) converges quadratically, Jacobi (5.8) linearly, on a signature model (Tables 5-1, 5-2)."""

import numpy as np

from armcal.kinematics import ik

RESOLUTION = 1e-5  # rad, an encoder count of a few arc-seconds


def _signature(design, seed):
    """The design model with its lengths off by ~1 mm and angles by ~0.1 deg (Stone 5.4's 'typical')."""
    rng = np.random.default_rng(seed)
    p = design.parameters.nominal.copy()
    for i, e in enumerate(design.parameters.entries):
        if e.free:
            p[i] += rng.normal() * (1.0 if e.kind == "length" else np.radians(0.1))
    return p


def _radial_errors(step, iterations):
    return [step(k) for k in range(iterations)]


def test_newton_quadratic_and_jacobi_linear(puma_models):
    design = puma_models["puma560_dh"]
    p_signature = _signature(design, 3)
    # away from degenerate configurations (5.2): wrist bent, elbow bent, shoulder clear of the limits
    rng = np.random.default_rng(4)
    low = np.radians([-90, -150, 30, -90, 20, -90])
    high = np.radians([90, -30, 150, 90, 80, 90])
    q_true = rng.uniform(low, high, (20, 6)) * rng.choice([1, 1, 1, 1, -1, 1], size=6)
    targets = design.tool_poses(q_true, p_signature)
    start = ik.solve(design, ik.pose_goals(targets), q_true).q  # q_0 = F_d^-1(T*): the design model's inverse

    def newton(k):
        q = ik.solve(design, ik.pose_goals(targets), start, p=p_signature, max_iterations=k, tol_position=0, tol_rotation=0).q
        return np.linalg.norm(design.tool_poses(q, p_signature)[:, :3, 3] - targets[:, :3, 3], axis=1)

    def jacobi(k):
        return ik.jacobi(design, design, targets, start, p_signature=p_signature, max_iterations=k).position_error

    e_newton = np.array(_radial_errors(newton, 8))  # (iteration, goal), mm
    e_jacobi = np.array(_radial_errors(jacobi, 14))
    assert np.all(e_newton[0] > 1.0)  # the design model misses by millimetres
    # quadratic near the solution: e_{k+1} <= C e_k^2 (Table 5-1)
    near = (e_newton[:-1] > 1e-7) & (e_newton[:-1] < 0.05)
    assert near.sum() >= 20
    assert np.all(e_newton[1:][near] <= 2.0 * e_newton[:-1][near] ** 2 + 1e-10)
    # linear: a steady factor per iteration, far above what a quadratic rate would give (Table 5-2)
    near = (e_jacobi[:-1] > 1e-6) & (e_jacobi[:-1] < 0.05)
    ratio = e_jacobi[1:][near] / e_jacobi[:-1][near]
    assert near.sum() >= 20 and 0.001 < np.median(ratio) < 0.9
    assert np.median(ratio / e_jacobi[:-1][near]) > 20.0  # e_{k+1} / e_k^2 is large: not quadratic
    # both reach the joint encoders' resolution
    assert e_newton[-1].max() < 1e-6
    final = ik.jacobi(design, design, targets, start, p_signature=p_signature, resolution=RESOLUTION)
    assert final.converged.all() and final.position_error.max() < 0.02  # 1e-5 rad at a 1 m reach is 0.01 mm
