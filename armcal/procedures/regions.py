"""The robot's working region, and random poses whose measured point lies in it (armcal plan --region).

A working region is an axis-aligned box in the robot base frame (mm) where the calibrated robot is to be
accurate:
  - ``iso_cube``: the ISO 9283 cube (ISO 9283:1998 6.2), where the spec's ``report.iso9283_cube`` puts it, else
    the largest cube the robot reaches near its workspace's centre (procedures/placement.py, as the certificate's
    ISO 9283 task places it);
  - ``grid``: the box of Stone's grid (7.2.1, Table 7-1: 60 x 30 x 50 cm), where the design model reaches it
    there, else scaled and placed in the robot's own workspace (placement.py, as the grid task places it).
The point is the one the tasks use: the instrument's one measured target (a tracker's reflector), else the tool.

Poses in the region (``region_candidates``), those the instrument reads only:
  - at any orientation: configurations uniform within the joint limits, kept where the point lies in the box (the
    random poses of a cell that works in that box, with any orientation the joints allow);
  - at the task's orientation (``Region.oriented``): points uniform in the box at the placement's orientation (Stone
    7.2.1's, tool pointing down), solved by inverse kinematics (Stone 5.4): a cell that works at one orientation.
    Such poses alone do not identify the base parameters; they serve as held-out poses and as the weight W.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.devices.base import DeviceModel
from armcal.errors import UserError
from armcal.kinematics import ik
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import compose, rot_y, rot_z
from armcal.procedures import pose_selection as ps
from armcal.spec.document import Spec

REGIONS = ("iso_cube", "grid")
BATCH = 50_000  # joint-space samples drawn at a time
MAX_SAMPLES = 4_000_000  # at most, per call: a region this rare is a mistake


@dataclass(frozen=True)
class Region:
    """An axis-aligned box (mm, robot base frame) that a frame of the robot works in."""

    name: str
    low: np.ndarray
    high: np.ndarray
    frame: str | None  # the robot target whose position counts (None: the tool)
    how: str
    rotation: np.ndarray  # (3, 3) the task's orientation of the frame (the placement's)
    oriented: bool = False  # poses at the task's orientation (inverse kinematics) rather than any the joints allow

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3), mm, lie in the box."""
        return ((points >= self.low) & (points <= self.high)).all(axis=1)

    def describe(self) -> dict:
        return {"name": self.name, "low": self.low.tolist(), "high": self.high.tolist(), "unit": "mm",
                "point": self.frame or "tool", "placement": self.how,
                "orientation": "the task's (inverse kinematics)" if self.oriented else "any the joints allow"}


def working_region(spec: Spec, kinematics: KinematicModel, name: str, oriented: bool = False) -> Region:
    """The box ``name`` (iso_cube, grid) for the spec's robot (module doc), its poses at the task's orientation
    where ``oriented``; a UserError where it is not reachable."""
    from armcal.evaluate.grid import grid_control, measured_point
    from armcal.procedures.placement import placed

    frame, p = measured_point(spec), kinematics.parameters.nominal
    if name == "iso_cube":
        cube = spec.report.iso9283_cube
        if cube is not None:
            centre, side, how = np.array([cube.x, cube.y, cube.z]), cube.side, "the spec's report.iso9283_cube"
            rotation = compose(rot_y(np.pi), rot_z(np.pi / 2))[:3, :3]  # as evaluate/grid.py's ISO 9283 task
        else:
            stands = placed("iso9283", kinematics, p, frame)
            if stands is None:
                raise UserError("--region iso_cube: the robot's design model reaches no ISO 9283 cube near the centre of its workspace")
            centre, side, how, rotation = stands.centre, stands.size, stands.how, stands.frames[0, :3, :3]
        return Region(name, centre - side / 2, centre + side / 2, frame, how, rotation, oriented)
    if name == "grid":
        solved = grid_control(kinematics, p, frame)
        if solved is None:
            raise UserError("--region grid: the robot's design model reaches Stone's grid neither at Table 7-1 nor scaled in its workspace")
        frames = solved[1].frames
        return Region(name, frames[:, :3, 3].min(axis=0), frames[:, :3, 3].max(axis=0), frame, solved[1].how, frames[0, :3, :3], oriented)
    raise UserError(f"--region {name}: choose one of {', '.join(REGIONS)}")


def region_candidates(spec: Spec, kinematics: KinematicModel, device: DeviceModel, region: Region, count: int, seed: int) -> ps.Candidates:
    """``count`` random poses uniform within the joint limits whose point lies in ``region`` and that the instrument
    reads (tracker, theodolite); fewer where MAX_SAMPLES draws do not find so many. An ``oriented`` region's:
    points uniform in the box at the task's orientation, solved by inverse kinematics (Stone 5.4, several starts;
    of the solutions within the limits the one nearest the middle of the limits: one arm configuration)."""
    rng = np.random.default_rng(seed)
    if region.oriented:
        return _oriented_candidates(spec, kinematics, device, region, count, rng)
    low, high = kinematics.limits[:, 0], kinematics.limits[:, 1]
    found, drawn, outside = [], 0, 0
    while sum(len(c) for c in found) < count and drawn < MAX_SAMPLES:
        Q = rng.uniform(low, high, (BATCH, kinematics.dof))
        poses = kinematics.target_poses(region.frame, Q) if region.frame else kinematics.tool_poses(Q)
        inside = region.contains(poses[:, :3, 3])
        drawn, outside = drawn + BATCH, outside + int((~inside).sum())
        if inside.any():
            found.append(ps.keyed_candidates(Q[inside], kinematics, device))
    if not found:
        return ps.Candidates(np.zeros((0, kinematics.dof)), (), {"outside the working region": outside})
    poses = ps.Candidates.joined(found)
    keep = min(count, len(poses))
    return ps.Candidates(poses.q[:keep], poses.keys[:keep], {"outside the working region": outside, **poses.dropped})


def _oriented_candidates(spec, kinematics, device, region: Region, count: int, rng: np.random.Generator) -> ps.Candidates:
    found, unreached, tried = [], 0, 0
    while sum(len(c) for c in found) < count and tried < 20 * count:
        size = 2 * count
        goals = np.repeat(np.eye(4)[None], size, axis=0)
        goals[:, :3, :3], goals[:, :3, 3] = region.rotation, rng.uniform(region.low, region.high, (size, 3))
        Q = ik.solve_from_starts(kinematics, ik.pose_goals(goals), frame=region.frame, seed=int(rng.integers(2**31)))
        reached = ~np.isnan(Q).any(axis=1)
        tried, unreached = tried + size, unreached + int((~reached).sum())
        if reached.any():
            found.append(ps.keyed_candidates(Q[reached], kinematics, device))
    dropped = {"unreachable at the task's orientation": unreached} if unreached else {}
    if not found:
        return ps.Candidates(np.zeros((0, kinematics.dof)), (), dropped)
    poses = ps.Candidates.joined(found)
    keep = min(count, len(poses))
    return ps.Candidates(poses.q[:keep], poses.keys[:keep], {**dropped, **poses.dropped})
