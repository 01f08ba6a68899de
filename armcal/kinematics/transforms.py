"""Paul's primitive homogeneous transforms (Stone App. A), numeric or symbolic.

Each function works on floats (returning a numpy 4x4) and on CasADi SX/MX
(returning a CasADi 4x4), so one definition serves the compiled model and the
numeric conversions.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

_SYMBOLIC = (ca.SX, ca.MX, ca.DM)


def _is_symbolic(*values) -> bool:
    return any(isinstance(v, _SYMBOLIC) for v in values)


def _matrix(rows, symbolic: bool):
    if symbolic:
        return ca.vertcat(*[ca.horzcat(*row) for row in rows])
    return np.array(rows, dtype=float)


def _cos_sin(angle):
    if isinstance(angle, _SYMBOLIC):
        return ca.cos(angle), ca.sin(angle)
    return np.cos(angle), np.sin(angle)


def trans(x, y, z):
    """Trans(x, y, z)."""
    return _matrix([[1, 0, 0, x], [0, 1, 0, y], [0, 0, 1, z], [0, 0, 0, 1]], _is_symbolic(x, y, z))


def rot_x(angle):
    """Rot(x, angle)."""
    c, s = _cos_sin(angle)
    return _matrix([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], _is_symbolic(angle))


def rot_y(angle):
    """Rot(y, angle)."""
    c, s = _cos_sin(angle)
    return _matrix([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], _is_symbolic(angle))


def rot_z(angle):
    """Rot(z, angle)."""
    c, s = _cos_sin(angle)
    return _matrix([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], _is_symbolic(angle))


def compose(*matrices):
    """Product of homogeneous transforms, left to right."""
    result = matrices[0]
    for matrix in matrices[1:]:
        result = ca.mtimes(result, matrix) if _is_symbolic(result, matrix) else result @ matrix
    return result


def xyz_zyx(x, y, z, rz, ry, rx):
    """Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx): a pose, and Goswami's link transform (3)."""
    return compose(trans(x, y, z), rot_z(rz), rot_y(ry), rot_x(rx))


def xyz_zyx_stacked(x, y, z, rz, ry, rx) -> np.ndarray:
    """xyz_zyx of N poses at once, from arrays (N,): (N, 4, 4), numeric only."""
    count = len(x)
    out = np.array(np.broadcast_to(np.eye(4), (count, 4, 4)))
    out[:, :3, 3] = np.stack([x, y, z], axis=1)
    for axis, angle in ((2, rz), (1, ry), (0, rx)):
        i, j = (axis + 1) % 3, (axis + 2) % 3  # Rot(axis) turns i towards j: rot_x (1, 2), rot_y (2, 0), rot_z (0, 1)
        turn = np.array(np.broadcast_to(np.eye(4), (count, 4, 4)))
        c, s = np.cos(angle), np.sin(angle)
        turn[:, i, i], turn[:, j, j], turn[:, i, j], turn[:, j, i] = c, c, -s, s
        out = out @ turn
    return out


def inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of a numeric homogeneous transform."""
    R, p = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ p
    return out


def pose_from_matrix(T: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """(x, y, z, rz, ry, rx) such that xyz_zyx(...) == T (ZYX Euler angles, ry in [-pi/2, pi/2]).

    ry and rx are read from Rot(z, rz)^-1 R = Rot(y, ry) Rot(x, rx), whose entries are all well scaled: near
    gimbal lock (ry close to +-pi/2) rz is ill-determined, and rx then absorbs its error, so the angles give R
    back to rounding error where reading rx from R directly would lose up to half the digits. In the lock
    itself (to 1e-15) only rz - rx (or rz + rx) is defined, and all of it goes into rz.
    """
    R = T[:3, :3]
    if np.hypot(R[0, 0], R[1, 0]) > 1e-15:
        rz = float(np.arctan2(R[1, 0], R[0, 0]))
    else:
        rz = float(np.arctan2(-R[0, 1], R[1, 1]))
    M = rot_z(-rz)[:3, :3] @ R
    ry = float(np.arctan2(-M[2, 0], M[0, 0]))
    rx = float(np.arctan2(-M[1, 2], M[1, 1]))
    return float(T[0, 3]), float(T[1, 3]), float(T[2, 3]), rz, ry, rx


POSE_FIELDS = ("x", "y", "z", "rz", "ry", "rx")  # the fields of a spec pose, in xyz_zyx's order


def rigid_registration(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The rigid transform (4x4) that best maps points ``source`` (N, 3) onto ``target`` (Kabsch)."""
    a, b = source.mean(axis=0), target.mean(axis=0)
    U, _, Vt = np.linalg.svd((source - a).T @ (target - b))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, b - R @ a
    return T


def on_sphere(centre: np.ndarray, radius: float, latitude, longitude) -> np.ndarray:
    """The point(s) at ``latitude``, ``longitude`` (rad, scalars or (M,) arrays) on the sphere of ``radius`` about
    ``centre``: (3,) or (M, 3)."""
    latitude, longitude = np.asarray(latitude, dtype=float), np.asarray(longitude, dtype=float)
    direction = np.stack([np.cos(latitude) * np.cos(longitude), np.cos(latitude) * np.sin(longitude), np.sin(latitude)], axis=-1)
    return centre + radius * direction
