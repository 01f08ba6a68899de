"""Laser tracker (or CMM, or any 3D point device): a target's position in the instrument frame.

A key is (target,). Readings: x, y, z = scale * (P p) with P the robot base in
the instrument frame; with ``orientation``, also rx, ry, rz, the intrinsic XYZ
Euler angles of the target frame in the instrument frame (R = Rx Ry Rz).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.devices.base import Channel, DeviceModel, Key, declared
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, parameter_entry, pose_entries
from armcal.spec.device import Tracker

POSITION = tuple(Channel(c, "length") for c in ("x", "y", "z"))
ORIENTATION = tuple(Channel(c, "angle") for c in ("rx", "ry", "rz"))


def intrinsic_xyz(R):
    """(rx, ry, rz) with R = Rot(x, rx) Rot(y, ry) Rot(z, rz); ry in [-pi/2, pi/2]."""
    rx = ca.atan2(-R[1, 2], R[2, 2])
    ry = ca.asin(ca.fmin(ca.fmax(R[0, 2], -1), 1))
    rz = ca.atan2(-R[0, 1], R[0, 0])
    return rx, ry, rz


class TrackerModel(DeviceModel):
    type = "tracker"

    def __init__(self, spec: Tracker):
        self.spec = spec
        entries = pose_entries("robot_base", spec.robot_base)
        entries.append(parameter_entry("tracker.scale", "scale", spec.scale))
        self.parameters = ParameterSet(tuple(entries))

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return POSITION + (ORIENTATION if self.spec.orientation else ())

    def target(self, key: Key) -> str | None:
        return key[0]

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        seen = ca.mtimes(pose_from_symbols(sym, "robot_base"), pose)
        readings = [sym["tracker.scale"] * seen[:3, 3]]
        if self.spec.orientation:
            readings += list(intrinsic_xyz(seen[:3, :3]))
        return ca.vertcat(*readings)

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        readings = np.atleast_2d(readings)
        sigma = np.full(readings.shape, declared(self.spec.noise))
        if self.spec.orientation:
            sigma[:, 3:] = declared(self.spec.orientation_noise)
        return sigma

    def noise_field(self, key: Key, channel: str) -> str:
        return "orientation_noise" if channel in ("rx", "ry", "rz") else "noise"

    def noise_kind(self, field: str) -> str:
        return "orientation" if field == "orientation_noise" else "position"
