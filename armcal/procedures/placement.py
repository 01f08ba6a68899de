"""Evaluation tasks placed in a robot's own workspace: Stone's grid (7.2.1) and the ISO 9283 cube.

Stone's grid stands where the PUMA 560 reaches it (Table 7-1). Another robot gets the same twelve
vertices, the 60 x 30 x 50 cm box scaled by its horizontal reach over the PUMA's (a2 + d4 of Table
6-2, 865 mm; 3/4 or 1/2 of that where the full size does not fit), at the reachable place nearest
the centre of its workspace. The ISO 9283 cube (ISO 9283:1998
6.2: the largest cube inside the working space, in its most used part, edges parallel to the base
frame; test poses P1..P5 on its diagonal plane) is the largest whose corners and test poses the
robot reaches, at the same places. Reachable means: the design model's inverse kinematics (Stone
5.4, many starts) within the joint limits, the tool pointing as in 7.2.1 (Rot(y, 180) Rot(z, 90)),
or, where the robot cannot point so (a SCARA's tool may point up), as it points at its workspace's
centre. The workspace is sampled at random configurations within the joint limits; its centre is
taken straight ahead of the robot (where the arm points at mid-limits), at the median horizontal
reach and height of the samples.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from armcal.kinematics import ik
from armcal.kinematics.transforms import compose, rot_y, rot_z
from armcal.procedures.tasks import GRID_VERTICES_CM, iso9283_cube

PUMA_REACH = 865.0  # mm: a2 + d4 of the PUMA 560 (Stone Table 6-2), the arm Table 7-1 was drawn for
SAMPLES = 2000  # random configurations that map the workspace
STEP = 0.15  # candidate centres: the workspace's centre and its neighbours this fraction of the reach away
BISECTIONS = 7  # the cube's side to 2 reach / 2^7 (1.6 % of the reach)
GRID_SHRINK = (1.0, 0.75, 0.5)  # the grid tried at the robot's size, then smaller
CUBE_CENTRES = 4  # the candidate centres nearest the workspace's centre that the cube is tried at
STARTS = 4  # inverse kinematics per frame starts from the sampled configurations nearest it


@dataclass(frozen=True)
class Placement:
    """Where a task stands: the frames to reach (N, 4, 4), in mm, and how they were chosen."""

    frames: np.ndarray
    centre: np.ndarray  # mm, robot base (world) frame
    size: float  # the grid's scale (1: Table 7-1's size), or the cube's side in mm
    how: str


class Workspace:
    """The reachable positions of a frame (the tool, or a measured target) of the design model."""

    def __init__(self, kinematics, p: np.ndarray, frame: str | None, seed: int = 0):
        self.kinematics, self.p, self.frame = kinematics, p, frame
        low, high = kinematics.limits[:, 0], kinematics.limits[:, 1]
        self.samples = np.random.default_rng(seed).uniform(low, high, (SAMPLES, kinematics.dof))
        poses = kinematics.target_poses(frame, self.samples, p) if frame else kinematics.tool_poses(self.samples, p)
        self.poses = poses
        base = kinematics.link_frames(np.zeros(kinematics.dof), p)[0][:3, 3]
        offsets = poses[:, :3, 3] - base
        self.reach = float(np.max(np.linalg.norm(offsets[:, :2], axis=1)))  # horizontal, as a maker's reach
        middle = (kinematics.tool_poses((low + high)[None] / 2, p)[0][:3, 3] - base)[:2]  # where the arm points at mid-limits
        ahead = middle / np.linalg.norm(middle) if np.linalg.norm(middle) > 1e-9 else np.array([1.0, 0.0])
        radius = np.median(np.linalg.norm(offsets[:, :2], axis=1))
        self.centre = base + np.array([*(radius * ahead), np.median(offsets[:, 2])])  # the median reach, straight ahead
        nearest = poses[np.argmin(np.linalg.norm(poses[:, :3, 3] - self.centre, axis=1))]
        stone = compose(rot_y(np.pi), rot_z(np.pi / 2))[:3, :3]
        self.orientations = [("Stone 7.2.1's, tool pointing down", stone), ("the robot's at its workspace's centre", nearest[:3, :3])]
        lattice = sorted(itertools.product((-1, 0, 1), repeat=3), key=lambda o: (np.abs(o).sum(), o))
        self.centres = self.centre + STEP * self.reach * np.array(lattice, dtype=float)

    def reached(self, frames: np.ndarray) -> np.ndarray:
        """Whether the design model reaches each frame (..., 4, 4) within its joint limits: Newton-Raphson (Stone 5.4)
        from the STARTS sampled configurations whose frames are nearest (position, and orientation at the reach's scale)."""
        shape, goals = frames.shape[:-2], frames.reshape(-1, 4, 4)
        position = np.linalg.norm(goals[:, None, :3, 3] - self.poses[None, :, :3, 3], axis=2)
        turn = np.linalg.norm((goals[:, None, :3, :3] - self.poses[None, :, :3, :3]).reshape(len(goals), SAMPLES, 9), axis=2)
        nearest = np.argsort(position + self.reach * turn / 2, axis=1)[:, :STARTS]
        solved = ik.solve(self.kinematics, np.repeat(ik.pose_goals(goals), STARTS, axis=0), self.samples[nearest.ravel()],
                          frame=self.frame, p=self.p, tol_position=1e-4, tol_rotation=1e-6)
        good = solved.converged & ik.within_limits(self.kinematics, ik.wrap_into_limits(self.kinematics, solved.q))
        return good.reshape(len(goals), STARTS).any(axis=1).reshape(shape)


def _oriented(points: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    frames = np.repeat(np.eye(4)[None], points.shape[0], axis=0)
    frames[:, :3, :3], frames[:, :3, 3] = rotation, points
    return frames


def place_grid(space: Workspace) -> Placement | None:
    """Table 7-1's vertices scaled to the robot (or to 3/4 or 1/2 of that), at the first candidate centre (nearest the
    workspace's) where every vertex is reached; None where none is."""
    vertices = 10.0 * GRID_VERTICES_CM
    for (label, rotation), shrink in itertools.product(space.orientations, GRID_SHRINK):
        scale = shrink * space.reach / PUMA_REACH
        relative = scale * (vertices - (vertices.min(axis=0) + vertices.max(axis=0)) / 2)
        frames = np.array([_oriented(centre + relative, rotation) for centre in space.centres])
        ok = space.reached(frames).all(axis=1)
        if ok.any():
            k = int(np.argmax(ok))
            how = (f"Table 7-1's grid scaled by {scale:.3g} ({shrink:g} x the robot's reach {space.reach:.0f} mm over the PUMA's {PUMA_REACH:.0f} mm), "
                   f"placed by armcal nearest the workspace's centre; orientation {label}")
            return Placement(frames[k], space.centres[k], scale, how)
    return None


def place_cube(space: Workspace) -> Placement | None:
    """The largest cube whose corners and P1..P5 are reached, over the candidate centres nearest the workspace's; its
    test poses P1..P5. None where not even a small cube is reached."""
    corners = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))
    centres = space.centres[:CUBE_CENTRES]
    for label, rotation in space.orientations:
        low, high = np.zeros(len(centres)), np.full(len(centres), 2.0 * space.reach)
        for _ in range(BISECTIONS):
            side = (low + high) / 2
            frames = np.array([np.concatenate([_oriented(c + s * corners, rotation), iso9283_cube(c, s, rotation)]) for c, s in zip(centres, side)])
            ok = space.reached(frames).all(axis=1)
            low, high = np.where(ok, side, low), np.where(ok, high, side)
        if low.max() > 0:
            k = int(np.argmax(low))
            how = f"the largest cube the robot reaches (corners and P1..P5) near its workspace's centre, placed by armcal; orientation {label}"
            return Placement(iso9283_cube(centres[k], low[k], rotation), centres[k], float(low[k]), how)
    return None


_PLACED: dict[tuple, Placement | None] = {}  # per process: a design's placement serves every campaign and run of it


def placed(task: str, kinematics, p: np.ndarray, frame: str | None) -> Placement | None:
    """place_grid ("grid_task") or place_cube ("iso9283") for the design (chain, parameter values, frame), computed
    once per process: the placement depends on nothing else."""
    key = (task, kinematics.joint_names, tuple(kinematics.parameters.names), kinematics.limits.tobytes(), np.asarray(p, dtype=float).tobytes(), frame)
    if key not in _PLACED:
        _PLACED[key] = (place_grid if task == "grid_task" else place_cube)(Workspace(kinematics, p, frame))
    return _PLACED[key]

