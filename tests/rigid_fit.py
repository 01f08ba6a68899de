"""An independent rigid registration for tests: Kabsch's SVD least squares, numpy only."""

import numpy as np


def kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """The rigid transform T (4 x 4) with Q ~ T P, points as rows (least squares)."""
    cp, cq = P.mean(axis=0), Q.mean(axis=0)
    U, _, Vt = np.linalg.svd((P - cp).T @ (Q - cq))
    R = Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, cq - R @ cp
    return T
