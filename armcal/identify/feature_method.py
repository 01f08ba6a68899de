"""Stone's method as a fit: circle-point features -> the parameters of a ``dh`` spec robot.

The pseudo-DH model of the features (4.71) starts at S_0 as the sensor sees it,
so the instrument-to-base transform becomes S_0 times the inverse of the robot's
(fixed) mounting frame; each target's position on its link is the mean of its
measured positions brought into that link's frame by the identified chain.
"""

from __future__ import annotations

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.support.errors import UserError
from armcal.identify.stone_features import FeatureIdentification, identify
from armcal.kinematics.conventions import dh_links_stacked
from armcal.kinematics.params import ParameterSet
from armcal.kinematics.smodel import DHRow, PseudoDH
from armcal.kinematics.transforms import inverse, pose_from_matrix, xyz_zyx
from armcal.spec.document import Spec
from armcal.spec.procedure import CirclePoint
from armcal.spec_parts.robot import DHRobot

POSE = ("x", "y", "z", "rz", "ry", "rx")


def check_applicable(spec: Spec) -> None:
    if not isinstance(spec.procedure, CirclePoint):
        raise UserError("fit.method s_model_features needs a circle_point procedure (Stone 6.4)")
    if not isinstance(spec.robot, DHRobot):
        raise UserError(f"fit.method s_model_features identifies a dh robot, not {spec.robot.convention}")
    if not spec.device.fixes_positions:
        raise UserError(f"fit.method s_model_features needs measured target positions, not a {spec.device.type}")


MIN_SWEEP_DEG = 180.0  # Stone's assumption B-3 for the repeated least-squares features


def _check_sweep(source, joint: int, xyz: np.ndarray, q: np.ndarray, kind: str) -> None:
    """Stone's assumptions: enough points (a circle needs 3), a revolute sweep of 180 deg or more (B-3),
    points that span a plane (not collinear)."""
    where = f"{source}: joint {joint}"
    if len(xyz) < 3:
        raise UserError(f"{where} has {len(xyz)} measured positions; a circle or line needs at least 3")
    if kind == "revolute":
        span = float(np.degrees(np.ptp(q)))
        if span < MIN_SWEEP_DEG:
            raise UserError(f"{where} sweeps {span:.1f} deg; Stone's feature method needs at least {MIN_SWEEP_DEG:.0f} (assumption B-3)")
        spread = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
        if spread[1] < 1e-6 * spread[0]:
            raise UserError(f"{where}: the target's positions are collinear, no plane of rotation is defined (B-1)")


def feature_parameters(spec: Spec, points: Measurements, parameters: ParameterSet) -> tuple[np.ndarray, FeatureIdentification]:
    """The problem's parameter vector from Stone's features of position ``points`` (instrument frame)."""
    check_applicable(spec)
    robot = spec.robot
    procedure = spec.procedure
    sweeps = []
    for i, target in enumerate(procedure.targets):
        rows = np.array([key == (target,) for key in points.keys])
        xyz = np.stack([points.readings[c][rows] for c in "xyz"], axis=1)
        sweeps.append((xyz, points.q[rows, i]))
    for i, (xyz, q) in enumerate(sweeps, start=1):
        _check_sweep(points.source, i, xyz, q, robot.joints[i - 1].type)
    reference = [DHRow(j.theta.value, j.d.value, j.a.value, j.alpha.value) for j in robot.joints]
    joint_types = tuple(j.type for j in robot.joints)
    last = robot.targets[procedure.targets[-1]]
    found = identify(sweeps, joint_types, np.asarray(procedure.signature), reference, last_azimuth=np.arctan2(last.y.value, last.x.value))
    pseudo = found.pseudo_dh
    theta = parameters.nominal.copy()
    set_value = lambda name, value: theta.__setitem__(parameters.index(name), value)  # noqa: E731
    for name, row in zip(robot.joint_names(), pseudo.rows):
        for field in ("theta", "d", "a", "alpha"):
            set_value(f"{name}.{field}", getattr(row, field))
    base = xyz_zyx(*(getattr(robot.base, f).value for f in POSE))
    for field, value in zip(POSE, pose_from_matrix(pseudo.base @ inverse(base))):
        set_value(f"robot_base.{field}", value)
    for i, (target, (xyz, _)) in enumerate(zip(procedure.targets, sweeps), start=1):
        rows = np.array([key == (target,) for key in points.keys])
        frames = _link_frames(pseudo, points.q[rows], i)
        local = np.einsum("nij,nj->ni", np.linalg.inv(frames), np.c_[xyz, np.ones(len(xyz))])[:, :3]
        for field, value in zip("xyz", local.mean(axis=0)):
            set_value(f"{target}.{field}", value)
    return theta, found


def _link_frames(pseudo: PseudoDH, q: np.ndarray, link: int) -> np.ndarray:
    """Frames (N, 4, 4) of link ``link`` of the pseudo-DH model (4.71) at joints q (N, n): base A_1 ... A_link (2.9)."""
    frames = np.broadcast_to(pseudo.base, (len(q), 4, 4))
    for j, (row, kind) in enumerate(zip(pseudo.rows[:link], pseudo.joint_types)):
        moved = q[:, j] + (row.theta if kind == "revolute" else row.d)
        fixed = np.full(len(q), row.d if kind == "revolute" else row.theta)
        theta, d = (moved, fixed) if kind == "revolute" else (fixed, moved)
        frames = frames @ dh_links_stacked(theta, d, row.a, row.alpha)
    return frames
