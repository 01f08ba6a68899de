"""Where the fit starts: the nominal values, with an instrument-to-base transform registered from the data.

A laser tracker can stand anywhere: its transform to the robot base is unknown
by metres and tens of degrees, far outside what Levenberg-Marquardt recovers
from zero. When that transform is free, it starts at the rigid registration
(Kabsch / SVD) of the nominal model's target positions onto the measured ones;
components the spec holds (vary: false) keep their values. A spec whose
transform already explains the data better than the registration (a calibrated
spec, which carries the fitted transform) starts from its own values.
"""

from __future__ import annotations

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.identify.problem import Problem
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import pose_from_matrix

POSE = ("x", "y", "z", "rz", "ry", "rx")


def rigid_registration(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The rigid transform (4x4) that best maps points ``source`` (N, 3) onto ``target`` (Kabsch)."""
    a, b = source.mean(axis=0), target.mean(axis=0)
    U, _, Vt = np.linalg.svd((source - a).T @ (target - b))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, b - R @ a
    return T


def starting_values(problem: Problem, kinematics: KinematicModel, device: DeviceModel, data: Measurements) -> np.ndarray:
    """Nominal parameters, with a free tracker-to-base transform registered from the data."""
    theta = problem.parameters.nominal.copy()
    names = problem.parameters.names
    free = {e.name for e in problem.parameters.entries if e.free}
    if device.type != "tracker" or not any(f"robot_base.{f}" in free for f in POSE):
        return theta
    nominal, measured = [], []
    for key, rows in data.groups().items():
        nominal.append(kinematics.target_poses(key[0], data.q[rows])[:, :3, 3])
        measured.append(np.stack([data.readings[c][rows] for c in "xyz"], axis=1))
    registered = theta.copy()
    for field, value in zip(POSE, pose_from_matrix(rigid_registration(np.concatenate(nominal), np.concatenate(measured)))):
        if f"robot_base.{field}" in free:  # a component the spec holds keeps its value
            registered[names.index(f"robot_base.{field}")] = value
    cost = lambda t: float(np.sum(problem.evaluate(t)[0] ** 2))  # noqa: E731
    return registered if cost(registered) < cost(theta) else theta
