"""What every measurement model provides, and its composition with the robot's kinematics.

A device model maps the pose of a measured point in the robot base frame and
the device parameters to readings: g(T, p_device). Samples are grouped by a
key (which target, pivot, station...); h(q, p_robot, p_device) = g(fk(q, p_robot), p_device)
is one CasADi Function per key, evaluated for all samples of the key at once.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import cache

import casadi as ca
import numpy as np

from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet

Key = tuple[str | None, ...]


@dataclass(frozen=True)
class Channel:
    """One reading of a sample: its CSV column and kind (length or angle)."""

    name: str
    kind: str


class DeviceModel(ABC):
    """A measuring instrument as a function of the measured pose and its own parameters."""

    type: str
    parameters: ParameterSet
    spec: object  # the device section of the spec

    @property
    def identity(self) -> str:
        """Canonical form of what defines the model's functions."""
        return f"{self.spec.model_dump_json()}|{getattr(self, 'mode', '')}"

    @abstractmethod
    def channels(self, key: Key) -> tuple[Channel, ...]:
        """The readings of one sample of this key."""

    @abstractmethod
    def target(self, key: Key) -> str | None:
        """The robot target measured by samples of this key (None: not on the robot)."""

    @abstractmethod
    def readings(self, key: Key, pose: ca.SX, sym: dict[str, ca.SX]) -> ca.SX:
        """The readings of one sample, from the target's pose (4x4, robot base frame) and device parameters."""

    @cache
    def geometry(self, key: Key) -> ca.Function:
        """g(T[4x4] pose of the target in the robot base frame, pd) -> readings, one Function per key."""
        pose = ca.SX.sym("T", 4, 4)
        pd = ca.SX.sym("pd", len(self.parameters))
        readings = self.readings(key, pose, symbols(self.parameters, pd))
        return ca.Function(f"g_{self.type}", [pose, pd], [readings], ["T", "pd"], ["y"])

    @abstractmethod
    def sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Standard deviation of each reading (N, channels) from the device's noise model."""

    def measurable(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Which samples the instrument can read at all (N,) - every one unless it says otherwise."""
        return np.ones(len(readings), dtype=bool)

    def unreadable(self, measurements) -> list[tuple[int, str, str]]:
        """(data line, column, message) of readings this instrument cannot produce (outside its range)."""
        out = []
        for key, rows in measurements.groups().items():
            if self.target(key) is None:
                continue
            channels = self.channels(key)
            readings = np.stack([measurements.readings[c.name][rows] for c in channels], axis=1)
            for row in rows[~self.measurable(key, readings)]:
                line = int(measurements.rows[row]) if measurements.rows is not None else int(row) + 2
                out.append((line, channels[0].name, "reading outside the instrument's range (travel or range limits)"))
        return out

    def prepare(self, measurements):
        """Readings as the model predicts them (e.g. raw ranges compensated); unchanged by default."""
        return measurements

    def visible(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """Which true target poses (N, 4, 4) give a valid reading (N,)."""
        return self.measurable(key, self.evaluate(key, poses, pd))

    def measurement_function(self, kinematics: KinematicModel, key: Key) -> ca.Function:
        """h(q, p, pd) = g(fk_target(q, p), pd) for the samples of one key."""
        q = ca.SX.sym("q", kinematics.dof)
        p = ca.SX.sym("p", len(kinematics.parameters))
        pd = ca.SX.sym("pd", len(self.parameters))
        name = self.target(key)
        pose = kinematics.targets[name](q, p) if name is not None else ca.SX.eye(4)
        return ca.Function("h", [q, p, pd], [self.geometry(key)(pose, pd)], ["q", "p", "pd"], ["y"])

    def predict(
        self, kinematics: KinematicModel, key: Key, Q: np.ndarray, p: np.ndarray | None = None, pd: np.ndarray | None = None
    ) -> np.ndarray:
        """Readings (N, channels) of N samples of one key, one mapped call."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if len(Q) == 0:
            return np.zeros((0, len(self.channels(key))))
        p = kinematics.parameter_vector(p)
        pd = self.parameters.nominal if pd is None else np.asarray(pd, dtype=float)
        mapped = self.measurement_function(kinematics, key).map(len(Q))
        return np.array(mapped(Q.T, p, pd)).T

    def evaluate(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """Readings (N, channels) for given target poses (N, 4, 4), e.g. of a simulated true robot."""
        pd = self.parameters.nominal if pd is None else np.asarray(pd, dtype=float)
        poses = np.asarray(poses, dtype=float)
        if len(poses) == 0:
            return np.zeros((0, len(self.channels(key))))
        side_by_side = poses.transpose(1, 0, 2).reshape(4, 4 * len(poses))
        return np.array(self.geometry(key).map(len(poses))(side_by_side, pd)).T


def symbols(parameters: ParameterSet, pd: ca.SX) -> dict[str, ca.SX]:
    """Name -> element of the device parameter symbol."""
    return dict(zip(parameters.names, ca.vertsplit(pd)))


def position(pose: ca.SX) -> ca.SX:
    """The translation column of a 4x4 pose."""
    return pose[:3, 3]


def transform_point(frame, point):
    """frame (4x4) applied to a 3-vector."""
    return ca.mtimes(frame[:3, :3], point) + frame[:3, 3]
