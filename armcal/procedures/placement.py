"""Evaluation tasks placed in a robot's own workspace: Stone's grid (7.2.1) and the ISO 9283 cube, by search.

Stone's grid stands where the PUMA 560 reaches it (Table 7-1; evaluate/grid.py keeps it there for any robot that
reaches it). Another robot gets the same twelve vertices, the 60 x 30 x 50 cm box scaled about its centre, and the
ISO 9283 cube (ISO 9283:1998 6.2: the largest cube inside the working space, in its most used part, edges parallel
to the base frame; test poses P1..P5 on its diagonal plane, 10 % of the diagonal in from its corners). Both are
placed by a continuous search within what the design model reaches:

- candidate centres: the workspace's centre (straight ahead of the robot, where the arm points at mid-limits, at the
  median horizontal reach and height of random configurations within the joint limits) and its 26 neighbours
  STEP of the reach away;
- at each centre, bisection over the size (the grid's scale, the cube's side): a size counts as reached when every
  frame of the task and of the task grown by MARGIN (10 %) about its centre is reached, so that the placed task
  keeps off the edge of the workspace. The largest size wins, the centre nearest the workspace's on a tie; a
  centre whose upper bound falls below the best size found is dropped;
- reached means: the design model's inverse kinematics (Newton-Raphson, Stone 5.4) converges within the joint
  limits from one of the 16 sampled configurations nearest the frame, tried (STARTS) only for the frames not
  reached yet.

Orientation: a robot of six or more axes holds Stone's (Rot(y, 180) Rot(z, 90), the tool pointing down), or else
the orientation its tool has at its workspace's centre. A robot of fewer axes holds only a family of orientations:
a SCARA's tool points down and its turn about the vertical is free. Its goals are then a point and the tool's
axis (down, or as at the workspace's centre), the task is judged on position (the orientation the design model
takes at its solution is the desired one), and ``how`` says so; a chain that cannot hold an axis either is
placed by position alone. A robot reaching no task says why, with its reach and the sizes tried, or the flatness of
a workspace whose positions lie in a plane (a chain whose joints all move the point in one plane) (``unplaced``).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from armcal.kinematics import ik
from armcal.kinematics.transforms import compose, rot_y, rot_z
from armcal.procedures.tasks import GRID_VERTICES_CM, iso9283_cube

PUMA_REACH = 865.0  # mm: a2 + d4 of the PUMA 560 (Stone Table 6-2), the arm Table 7-1 was drawn for
SAMPLES = 2000  # random configurations that map the workspace
STEP = 0.15  # candidate centres: the workspace's centre and its neighbours this fraction of the reach away
MARGIN = 0.10  # a size counts as reached only where the task grown by this fraction about its centre is reached too
BISECTIONS = 8  # each size to 1/256 of its upper bound (the grown task's extent at twice the reach)
STARTS = (1, 3, 12)  # inverse kinematics of a frame starts from the sampled configurations nearest it: the nearest,
# then (for the frames not reached) the next 3 at once, then the next 12
ITERATIONS = 25  # Newton steps from a start: from a sampled configuration near the frame a reached frame needs far fewer
FLAT = 1e-6  # a workspace whose positions spread less than this fraction of their largest spread across some direction is flat
POSE, AXIS, POINT = 12, 6, 3  # goal widths (ik.error_function): a full pose; a point and the tool's axis; a point
JUDGED = {POSE: "judged on position and orientation",
          AXIS: "judged on position: the robot's {dof} axes hold the tool's axis, not its turn about it (the design model's at its solution)",
          POINT: "judged on position: the robot's {dof} axes hold no fixed direction of the tool here (its orientation: the design model's at its solution)"}


@dataclass(frozen=True)
class Placement:
    """Where a task stands: the frames to reach (N, 4, 4), in mm, and how they were chosen; ``goal``: the width of its
    inverse kinematics' goals (POSE, AXIS or POINT), what the robot holds of the frames; ``q``: joints (N, n) within the
    limits at which the design model reaches them, the search's certificate (None: not searched)."""

    frames: np.ndarray
    centre: np.ndarray  # mm, robot base (world) frame
    size: float  # the grid's scale (1: Table 7-1's size), or the cube's side in mm
    how: str
    goal: int = POSE
    q: np.ndarray | None = None


def goal_rows(frames: np.ndarray, width: int) -> np.ndarray:
    """Inverse kinematics' goals (N, width) of frames (N, 4, 4): [p, x, y, z axes], [p, z axis] or [p]."""
    rows = ik.pose_goals(frames)
    return {POSE: rows, AXIS: np.hstack([rows[:, :3], rows[:, 9:]]), POINT: rows[:, :3]}[width]


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
        held = [("Stone 7.2.1's, tool pointing down", stone, POSE), ("the robot's at its workspace's centre", nearest[:3, :3], POSE)]
        held = held if kinematics.dof >= 6 else []  # fewer axes hold no full orientation at will
        self.orientations = held + [("the tool's axis pointing down, its turn about it free", stone, AXIS),
                                    ("the tool's axis as at the workspace's centre, its turn about it free", nearest[:3, :3], AXIS),
                                    ("any", nearest[:3, :3], POINT)]
        lattice = sorted(itertools.product((-1, 0, 1), repeat=3), key=lambda o: (np.abs(o).sum(), o))
        self.centres = self.centre + STEP * self.reach * np.array(lattice, dtype=float)
        spread = np.linalg.svd(offsets - offsets.mean(axis=0), compute_uv=False) / np.sqrt(SAMPLES)  # mm, rms across each principal axis
        self.flat = (f"the positions it reaches lie in a {'plane' if spread[1] > FLAT * spread[0] else 'line'} (rms spread of "
                     f"{SAMPLES} random configurations across it {spread[2]:.2g} mm, along it {spread[0]:.0f} mm): no box stands in it"
                     if spread[2] < FLAT * spread[0] else "")
        self._errors: dict[int, object] = {}
        self.why: dict[str, str] = {}  # why a task (its name) was not placed: the reach, the smallest size tried, where

    def reached(self, frames: np.ndarray, width: int = POSE) -> np.ndarray:
        """Whether the design model reaches each frame (..., 4, 4) within its joint limits (solutions)."""
        return self.solutions(frames, width)[0]

    def solutions(self, frames: np.ndarray, width: int = POSE) -> tuple[np.ndarray, np.ndarray]:
        """Whether the design model reaches each frame (..., 4, 4) within its joint limits, the goal of the given width:
        Newton-Raphson (Stone 5.4) from the sampled configurations nearest the frame (position, and the goal's
        orientation part at the reach's scale): the nearest first, the next ones (STARTS) only for the frames not reached.
        Returns (reached (...), joints (..., n) within the limits reaching them, NaN where not reached)."""
        shape, frames = frames.shape[:-2], frames.reshape(-1, 4, 4)
        distance = np.linalg.norm(frames[:, None, :3, 3] - self.poses[None, :, :3, 3], axis=2)
        if width != POINT:
            columns = slice(0, 3) if width == POSE else slice(2, 3)
            turn = frames[:, None, :3, columns] - self.poses[None, :, :3, columns]
            distance = distance + self.reach / 2 * np.linalg.norm(turn.reshape(len(frames), SAMPLES, -1), axis=2)
        starts = sum(STARTS)
        nearest = np.argpartition(distance, starts, axis=1)[:, :starts]
        nearest = np.take_along_axis(nearest, np.argsort(np.take_along_axis(distance, nearest, axis=1), axis=1), axis=1)
        goals, done, todo = goal_rows(frames, width), np.zeros(len(frames), dtype=bool), np.arange(len(frames))
        Q = np.full((len(frames), self.kinematics.dof), np.nan)
        if width not in self._errors:
            self._errors[width] = ik.compiled_error(self.kinematics, self.frame, width, None)
        for first, count in zip(np.cumsum((0, *STARTS[:-1])), STARTS):
            if not len(todo):
                break
            starts = nearest[todo, first : first + count]
            solved = ik.solve(self.kinematics, np.repeat(goals[todo], count, axis=0), self.samples[starts.ravel()], frame=self.frame,
                              p=self.p, tol_position=1e-4, tol_rotation=1e-6, max_iterations=ITERATIONS, error=self._errors[width])
            wrapped = ik.wrap_into_limits(self.kinematics, solved.q)
            good = (solved.converged & ik.within_limits(self.kinematics, wrapped)).reshape(len(todo), count)
            first_good = np.argmax(good, axis=1)
            reached = good.any(axis=1)
            Q[todo[reached]] = wrapped.reshape(len(todo), count, -1)[np.flatnonzero(reached), first_good[reached]]
            done[todo[reached]] = True
            todo = todo[~reached]
        return done.reshape(shape), Q.reshape(*shape, -1)

    def judged(self, width: int) -> str:
        return JUDGED[width].format(dof=self.kinematics.dof)


def _oriented(points: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    frames = np.repeat(np.eye(4)[None], points.shape[0], axis=0)
    frames[:, :3, :3], frames[:, :3, 3] = rotation, points
    return frames


def _largest(space: Workspace, task, highest: float, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Bisection over size at every candidate centre: (sizes (C,), reached), the largest size (to highest / 2^BISECTIONS)
    at which ``task(centre, size)`` (frames (m, 4, 4)) and the task grown by MARGIN are reached; 0 where none is."""
    count = len(space.centres)
    low, high, alive = np.zeros(count), np.full(count, highest), np.ones(count, dtype=bool)
    for _ in range(BISECTIONS):
        rows = np.flatnonzero(alive)
        size = (low[rows] + high[rows]) / 2
        grown = np.array([task(space.centres[k], (1 + MARGIN) * s) for k, s in zip(rows, size)])
        ok = space.reached(grown, width).all(axis=1)  # the grown task first: where it is not reached, the size fails
        if ok.any():
            inner = np.array([task(space.centres[k], s) for k, s in zip(rows[ok], size[ok])])
            ok[ok] = space.reached(inner, width).all(axis=1)
        low[rows], high[rows] = np.where(ok, size, low[rows]), np.where(ok, high[rows], size)
        alive &= high > low.max()  # a centre that cannot beat the best size found is dropped
        if not alive.any():
            break
    return low, high


def _place(space: Workspace, task, highest: float, name: str, describe) -> Placement | None:
    """The first orientation family (Workspace.orientations) at which some size of ``task`` is reached, its largest."""
    if space.flat:
        space.why[name] = f"with a horizontal reach of {space.reach:.0f} mm, {space.flat}"
        return None
    for label, rotation, width in space.orientations:
        sizes, _ = _largest(space, lambda c, s: _oriented(task(c, s), rotation), highest, width)  # noqa: B023 (used at once)
        if sizes.max() > 0:
            k = int(np.argmax(sizes))  # the largest; on a tie the centre nearest the workspace's
            how = (f"{describe(sizes[k])}, the largest (to {highest / 2**BISECTIONS:.3g}) whose copy grown {MARGIN * 100:.0f} % about its "
                   f"centre the robot also reaches, found by bisection at {len(space.centres)} candidate centres around its workspace's centre, "
                   f"placed by armcal; orientation {label}; {space.judged(width)}")
            return Placement(_oriented(task(space.centres[k], sizes[k]), rotation), space.centres[k], float(sizes[k]), how, width, None)
    space.why[name] = (f"with a horizontal reach of {space.reach:.0f} mm, no {name} down to {describe(highest / 2**BISECTIONS)} "
                                    f"(grown {MARGIN * 100:.0f} %) is reached at any of {len(space.centres)} centres within {STEP * space.reach:.0f} mm of "
                                    f"the workspace's centre ({', '.join(f'{v:.0f}' for v in space.centre)}) mm, at any orientation the robot holds")
    return None


def grid_vertices(scale: float) -> np.ndarray:
    """Table 7-1's twelve vertices (mm) scaled by ``scale`` about the centre of their box."""
    vertices = 10.0 * GRID_VERTICES_CM
    return scale * (vertices - (vertices.min(axis=0) + vertices.max(axis=0)) / 2)


def _solved(space: Workspace, stands: Placement | None) -> Placement | None:
    """The placement with the joints that reach its frames (Placement.q)."""
    return None if stands is None else replace(stands, q=space.solutions(stands.frames, stands.goal)[1])


def place_grid(space: Workspace) -> Placement | None:
    """Table 7-1's vertices at the largest scale the robot reaches with margin (module doc); None where none is."""
    highest = 2 * space.reach / ((1 + MARGIN) * 10.0 * np.ptp(GRID_VERTICES_CM, axis=0).max())  # the grown grid as wide as the reach's diameter
    return _solved(space, _place(space, lambda c, s: c + grid_vertices(s), highest, "Stone's grid",
                                 lambda s: f"Table 7-1's grid scaled by {s:.3g} (the PUMA's reach {PUMA_REACH:.0f} mm, this robot's {space.reach:.0f} mm)"))


CORNERS = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))


def place_cube(space: Workspace) -> Placement | None:
    """The largest cube whose corners and P1..P5 the robot reaches with margin (module doc), as its test poses P1..P5;
    None where not even a small cube is reached."""
    stands = _place(space, lambda c, s: np.concatenate([c + s * CORNERS, iso9283_cube(c, s)[:, :3, 3]]), 2 * space.reach / (1 + MARGIN),
                    "ISO 9283 cube", lambda s: f"the cube of side {s:.0f} mm")
    if stands is None:
        return None
    poses = iso9283_cube(stands.centre, stands.size, stands.frames[0, :3, :3])
    return _solved(space, Placement(poses, stands.centre, stands.size, stands.how, stands.goal))


_PLACED: dict[tuple, Placement | None] = {}  # per process: a design's placement serves every campaign and run of it
_WHY: dict[tuple, str] = {}  # why placed() found none: Workspace.why, by placed()'s key
TASKS = {"grid_task": (place_grid, "Stone's grid"), "iso9283": (place_cube, "ISO 9283 cube")}


def _key(task: str, kinematics, p: np.ndarray, frame: str | None) -> tuple:
    return (task, kinematics.joint_names, tuple(kinematics.parameters.names), kinematics.limits.tobytes(), np.asarray(p, dtype=float).tobytes(), frame)


def placed(task: str, kinematics, p: np.ndarray, frame: str | None) -> Placement | None:
    """place_grid ("grid_task") or place_cube ("iso9283") for the design (chain, parameter values, frame), computed
    once per process: the placement depends on nothing else."""
    key = _key(task, kinematics, p, frame)
    if key not in _PLACED:
        space = Workspace(kinematics, p, frame)
        place, name = TASKS[task]
        _PLACED[key] = place(space)
        _WHY[key] = space.why.get(name, "")
    return _PLACED[key]


def unplaced(task: str, kinematics, p: np.ndarray, frame: str | None) -> str:
    """Why ``placed`` found no place for the task (its reach, the smallest size tried, where); '' where it did."""
    placed(task, kinematics, p, frame)
    return _WHY[_key(task, kinematics, p, frame)]
