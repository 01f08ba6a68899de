"""Evaluation tasks: Stone's three-dimensional grid (7.2.1, Table 7-1) and the ISO 9283 cube."""

from __future__ import annotations

import numpy as np

from armcal.kinematics.transforms import compose, rot_y, rot_z

# Table 7-1: vertex positions (cm) relative to the base of an ideal Puma 560
GRID_VERTICES_CM = np.array(
    [
        [-30.0, 40.0, 30.0],
        [30.0, 40.0, 30.0],
        [-30.0, 70.0, 30.0],
        [30.0, 70.0, 30.0],
        [-30.0, 40.0, 80.0],
        [30.0, 40.0, 80.0],
        [-30.0, 70.0, 80.0],
        [30.0, 70.0, 80.0],
        [0.0, 40.0, 30.0],
        [0.0, 70.0, 30.0],
        [0.0, 40.0, 80.0],
        [0.0, 70.0, 80.0],
    ]
)


def grid_task(origin: np.ndarray | None = None) -> np.ndarray:
    """The twelve desired end-effector frames (12, 4, 4) of Table 7-1, in mm.

    The orientation is Rot(y, 180) Rot(z, 90) at every vertex (7.2.1); ``origin``
    shifts the grid, e.g. to the height of a robot's base frame.
    """
    rotation = compose(rot_y(np.pi), rot_z(np.pi / 2))
    frames = np.repeat(rotation[None], 12, axis=0)
    frames[:, :3, 3] = 10.0 * GRID_VERTICES_CM + (np.zeros(3) if origin is None else origin)
    return frames


def iso9283_cube(centre: np.ndarray, side: float, rotation: np.ndarray | None = None) -> np.ndarray:
    """ISO 9283 test poses P1..P5 (5, 4, 4) on the cube's diagonal plane.

    P1 is the cube's centre; P2..P5 lie on the diagonals of the plane through two
    opposite edges, at 10 % of the diagonal's length from its corners.
    """
    centre = np.asarray(centre, dtype=float)
    half = side / 2
    corners = np.array([[-half, -half, -half], [half, half, -half], [half, half, half], [-half, -half, half]])
    points = [centre] + [centre + 0.8 * corner for corner in corners]  # 10 % in from each corner
    frames = np.repeat(np.eye(4)[None], 5, axis=0)
    if rotation is not None:
        frames[:, :3, :3] = rotation
    frames[:, :3, 3] = points
    return frames
