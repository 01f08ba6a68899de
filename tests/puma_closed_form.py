"""Stone's closed-form forward kinematics of the ideal PUMA 560, App. B (B.1)-(B.13).

Written out independently of armcal's transforms, as the oracle for the
compiled models. Lengths of Table 6-2 in mm; App. B names the shoulder offset
d3, which Table 6-2 lists as d2 = 14.909 cm.
"""

import numpy as np

A2, A3, D3, D4 = 431.8, -20.32, 149.09, 433.07  # Table 6-2, mm


def t6(theta: np.ndarray, o_z_as_printed: bool = False) -> np.ndarray:
    """T6 (B.1) for joint angles theta (N, 6) in rad -> (N, 4, 4)."""
    c = np.cos(theta).T
    s = np.sin(theta).T
    C1, C2, C4, C5, C6 = c[0], c[1], c[3], c[4], c[5]
    S1, S2, S4, S5, S6 = s[0], s[1], s[3], s[4], s[5]
    C23, S23 = np.cos(theta[:, 1] + theta[:, 2]), np.sin(theta[:, 1] + theta[:, 2])
    nx = C1 * (C23 * (C4 * C5 * C6 - S4 * S6) - S23 * S5 * C6) - S1 * (S4 * C5 * C6 + C4 * S6)  # (B.2)
    ny = S1 * (C23 * (C4 * C5 * C6 - S4 * S6) - S23 * S5 * C6) + C1 * (S4 * C5 * C6 + C4 * S6)  # (B.3)
    nz = -S23 * (C4 * C5 * C6 - S4 * S6) - C23 * S5 * C6  # (B.4)
    ox = C1 * (-C23 * (C4 * C5 * S6 + S4 * C6) + S23 * S5 * S6) - S1 * (-S4 * C5 * S6 + C4 * C6)  # (B.5)
    oy = S1 * (-C23 * (C4 * C5 * S6 + S4 * C6) + S23 * S5 * S6) + C1 * (-S4 * C5 * S6 + C4 * C6)  # (B.6)
    sign = -1.0 if o_z_as_printed else 1.0
    oz = sign * S23 * (C4 * C5 * S6 + S4 * C6) + C23 * S5 * S6  # (B.7), sign corrected
    ax = C1 * (C23 * C4 * S5 + S23 * C5) - S1 * S4 * S5  # (B.8)
    ay = S1 * (C23 * C4 * S5 + S23 * C5) + C1 * S4 * S5  # (B.9)
    az = -S23 * C4 * S5 + C23 * C5  # (B.10)
    reach = D4 * S23 + A3 * C23 + A2 * C2
    px = C1 * reach - D3 * S1  # (B.11)
    py = S1 * reach + D3 * C1  # (B.12)
    pz = -(-D4 * C23 + A3 * S23 + A2 * S2)  # (B.13)
    T = np.zeros((theta.shape[0], 4, 4))
    T[:, :3, 0] = np.stack([nx, ny, nz], axis=1)
    T[:, :3, 1] = np.stack([ox, oy, oz], axis=1)
    T[:, :3, 2] = np.stack([ax, ay, az], axis=1)
    T[:, :3, 3] = np.stack([px, py, pz], axis=1)
    T[:, 3, 3] = 1.0
    return T
