"""Link transforms of each convention, as functions of their parameters.

Each link function returns the transform from the frame on joint i's axis to
the frame on joint i+1's axis (the flange for the last joint), for a joint
variable already folded into its parameter.
"""

from __future__ import annotations

import numpy as np

from armcal.kinematics.transforms import compose, rot_x, rot_y, rot_z, trans, xyz_zyx


def dh_link(theta, d, a, alpha):
    """Denavit-Hartenberg A_i = Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha), Stone (2.9)."""
    return compose(rot_z(theta), trans(0, 0, d), trans(a, 0, 0), rot_x(alpha))


def dh_links_stacked(theta: np.ndarray, d: np.ndarray, a: float, alpha: float) -> np.ndarray:
    """dh_link of N joint values at once, from arrays (N,) theta and d: (N, 4, 4), numeric only, Stone (2.9) multiplied out."""
    ct, st, ca_, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    out = np.zeros((len(theta), 4, 4))
    out[:, 0] = np.stack([ct, -st * ca_, st * sa, a * ct], axis=1)
    out[:, 1] = np.stack([st, ct * ca_, -ct * sa, a * st], axis=1)
    out[:, 2, 1:] = sa, ca_, 0.0
    out[:, 2, 3] = d
    out[:, 3, 3] = 1.0
    return out


def mdh_link(theta, d, a, alpha, beta):
    """Hayati's modified DH: (2.9) followed by Rot(y, beta), well conditioned for near-parallel axes."""
    return compose(dh_link(theta, d, a, alpha), rot_y(beta))


def smodel_link(beta, d, a, alpha, gamma, b):
    """S-Model B_i = Rot(z, beta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha) Rot(z, gamma) Trans(0, 0, b), Stone (3.2)."""
    return compose(rot_z(beta), trans(0, 0, d), trans(a, 0, 0), rot_x(alpha), rot_z(gamma), trans(0, 0, b))


def six_parameter_link(x, y, z, alpha, beta, gamma):
    """Goswami's link transform T^L: Trans(x, y, z) then ZYX Euler angles alpha (z), beta (y), gamma (x), eq. (3)."""
    return xyz_zyx(x, y, z, alpha, beta, gamma)


def six_parameter_joint(value, revolute: bool):
    """Goswami's joint transform T^J: Rot(z, theta) or Trans(0, 0, d) with theta = theta0 + k q, eq. (2)."""
    return rot_z(value) if revolute else trans(0, 0, value)
