"""Random poses whose measured point lies in a working region (armcal plan --region).

A working region (``Region``) is an axis-aligned box in the robot base frame (mm) where the calibrated robot is to
be accurate; evaluate/working_region.py places it where the certificate's tasks stand. The point is the one the
tasks use: the instrument's one measured target (a tracker's reflector), else the tool.

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
from armcal.kinematics import ik
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures import pose_selection as ps
from armcal.spec.document import Spec

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
