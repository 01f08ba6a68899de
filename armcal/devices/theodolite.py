"""Theodolite network: azimuth and elevation of a target seen from each station.

A key is (station, target). A target seen from a station frame at (x, y, z):
azimuth = atan2(y, x), elevation = atan2(z, sqrt(x^2 + y^2)). Angles fix the
network only up to scale; a scale bar's two marks, sighted like targets (key
(station, "scale_bar.end1"|"scale_bar.end2")), plus its calibrated length (key
("scale_bar",), one reading) fix it.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.devices.base import Channel, DeviceModel, Key, declared, transform_point
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, pose_entries
from armcal.spec.device import Theodolite

BAR_ENDS = ("scale_bar.end1", "scale_bar.end2")
BAR_LENGTH: Key = ("scale_bar",)


def _inverse(frame):
    R, p = frame[:3, :3], frame[:3, 3]
    return ca.vertcat(ca.horzcat(R.T, -ca.mtimes(R.T, p)), ca.horzcat(0, 0, 0, 1))


class TheodoliteModel(DeviceModel):
    type = "theodolite"

    def __init__(self, spec: Theodolite):
        self.spec = spec
        entries = pose_entries("robot_base", spec.robot_base)
        for name, station in spec.stations.items():
            entries += pose_entries(f"station.{name}", station.pose)
        if spec.scale_bar is not None:
            for end, point in zip(BAR_ENDS, (spec.scale_bar.end1, spec.scale_bar.end2)):
                entries += pose_entries(end, point, ("x", "y", "z"))
        self.parameters = ParameterSet(tuple(entries))

    def with_calibrated_bar(self, pd: np.ndarray) -> np.ndarray:
        """Device parameters with the second mark moved along the bar so the marks are exactly its length apart."""
        if self.spec.scale_bar is None:
            return pd
        pd = np.asarray(pd, dtype=float).copy()
        first, second = ([self.parameters.index(f"{end}.{c}") for c in "xyz"] for end in BAR_ENDS)
        along = pd[second] - pd[first]
        pd[second] = pd[first] + along * self.spec.scale_bar.length / np.linalg.norm(along)
        return pd

    def channels(self, key: Key) -> tuple[Channel, ...]:
        if key == BAR_LENGTH:
            return (Channel("length", "length"),)
        return (Channel("azimuth", "angle"), Channel("elevation", "angle"))

    def target(self, key: Key) -> str | None:
        return None if key == BAR_LENGTH or key[1] in BAR_ENDS else key[1]

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        end = lambda name: ca.vertcat(*(sym[f"{name}.{c}"] for c in "xyz"))  # noqa: E731
        if key == BAR_LENGTH:
            return ca.norm_2(end(BAR_ENDS[1]) - end(BAR_ENDS[0]))
        station, target = key
        world = end(target) if target in BAR_ENDS else transform_point(pose_from_symbols(sym, "robot_base"), pose[:3, 3])
        local = transform_point(_inverse(pose_from_symbols(sym, f"station.{station}")), world)
        return ca.vertcat(ca.atan2(local[1], local[0]), ca.atan2(local[2], ca.sqrt(local[0] ** 2 + local[1] ** 2)))

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        shape = np.shape(np.atleast_2d(readings))
        if key == BAR_LENGTH:
            return np.full(shape, self.spec.scale_bar.noise)
        return np.full(shape, declared(self.spec.noise))

    def noise_field(self, key: Key, channel: str) -> str | None:
        return None if key == BAR_LENGTH else "noise"  # the bar's length is its certificate's, not a reading

    def noise_kind(self, field: str) -> str:
        return "angle"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        return {"station": key[0], "target": key[1]}
