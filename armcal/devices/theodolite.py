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

from typing import ClassVar, Literal

from pydantic import Field

from armcal.devices.base import Channel, DeviceModel, Key, declared, named_group, transform_point
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, pose_entries
from armcal.spec_parts.base import Length, SpecModel, declared_pose
from armcal.spec_parts.starter import mm, flange_point, random_poses
from armcal.spec_parts.instrument import ESTIMATE_HELP, GROUPS_HELP, AngleSigma, DeviceSpec, Point
from armcal.spec_parts.robot import Pose

BAR_ENDS = ("scale_bar.end1", "scale_bar.end2")
BAR_LENGTH: Key = ("scale_bar",)
BAR_SIGHTINGS = 3  # repeated sightings of each scale-bar mark per station


class Station(SpecModel):
    """A theodolite station: its pose in the instrument (world) frame."""

    pose: Pose = Field(description="station pose in the instrument (world) frame")


class ScaleBar(SpecModel):
    """A bar of calibrated length whose two end marks are sighted too; it fixes the network's scale."""

    length: Length = Field(gt=0.0, description="calibrated distance between the bar's marks")
    noise: Length = Field(0.01, gt=0.0, description="uncertainty of the calibrated length")
    end1: Point = Field(description="approximate position of the first mark, instrument frame")
    end2: Point = Field(description="approximate position of the second mark, instrument frame")


class Theodolite(DeviceSpec):
    """Theodolite network: azimuth and elevation of targets seen from each station."""

    type: Literal["theodolite"]
    stations: dict[str, Station] = Field(min_length=1, description="theodolite stations by name")
    targets: list[str] = Field(min_length=1, description="names of robot targets sighted")
    robot_base: Pose = Pose()
    noise: AngleSigma = Field(description="angle noise sigma (arc-seconds typically), or auto (estimated from the data)")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target", "station"]] = Field(["kind"], description=GROUPS_HELP)
    scale_bar: ScaleBar | None = Field(None, description="a bar of calibrated length; without it the network's scale is not identifiable")

    reading_kind: ClassVar[str] = "angle"
    locates_targets: ClassVar[bool] = True
    held_out_metric: ClassVar[str] = "angle error (azimuth, elevation)"

    def parameter_location(self, name: str) -> list[str]:
        head, _, field = name.rpartition(".")
        if head.startswith("station."):
            return ["device", "stations", head.split(".", 1)[1], "pose", field]
        if head in BAR_ENDS:
            return ["device", "scale_bar", head.split(".", 1)[1], field]
        return super().parameter_location(name)

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`\'s targets and sections (``dof`` joints, ``s`` times the PUMA 560\'s size): Two stations and a scale bar, the robot in front of the baseline; random poses."""
        fixed = "{value: 0, vary: false}"
        return [flange_point(dof, "ball")], [
            "device:",
            "  type: theodolite",
            "  # World frame at station t1; the robot stands in front of the baseline (as specs/puma560_theodolite.yaml).",
            "  stations:",
            f"    t1: {{pose: {{x: {fixed}, y: {fixed}, z: {fixed}}}}}",
            f"    t2: {{pose: {{x: {mm(3000 * s)}, y: 0.0, z: 0.0}}}}",
            "  targets: [ball]",
            f"  robot_base: {{x: {mm(1500 * s)}, y: {mm(2500 * s)}, z: {mm(-1200 * s)}, rz: -90.0, ry: 0.0, rx: 0.0}}",
            "  noise: 2 arcsec",
            "  scale_bar:   # fixes the network's scale: its calibrated length and its marks' rough positions",
            f"    length: {mm(1000 * s)}",
            "    noise: 0.01",
            f"    end1: {{x: {mm(1000 * s)}, y: {mm(1500 * s)}, z: {mm(-1000 * s)}}}",
            f"    end2: {{x: {mm(2000 * s)}, y: {mm(1500 * s)}, z: {mm(-1000 * s)}}}",
            "procedure:",
            *random_poses(150, 3),
            "validation:",
            *random_poses(75, 4),
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        return ("theodolite network" + (" with scale bar" if self.scale_bar else ""),
                [f"stations {', '.join(self.stations)}", f"targets {', '.join(self.targets)}"])


def _inverse(frame):
    R, p = frame[:3, :3], frame[:3, 3]
    return ca.vertcat(ca.horzcat(R.T, -ca.mtimes(R.T, p)), ca.horzcat(0, 0, 0, 1))


class TheodoliteModel(DeviceModel):
    type = "theodolite"
    section = Theodolite
    key_columns = ("station", "target")
    off_robot_targets = BAR_ENDS

    def __init__(self, spec: Theodolite):
        self.spec = spec
        entries = pose_entries("robot_base", declared_pose(spec.robot_base))
        for name, station in spec.stations.items():
            entries += pose_entries(f"station.{name}", declared_pose(station.pose))
        if spec.scale_bar is not None:
            for end, point in zip(BAR_ENDS, (spec.scale_bar.end1, spec.scale_bar.end2)):
                entries += pose_entries(end, declared_pose(point))
        self.parameters = ParameterSet(tuple(entries))

    def true_parameters(self, pd: np.ndarray) -> np.ndarray:
        """Device parameters with the second mark moved along the bar so the marks are exactly its length apart."""
        if self.spec.scale_bar is None:
            return pd
        pd = np.asarray(pd, dtype=float).copy()
        first, second = ([self.parameters.index(f"{end}.{c}") for c in "xyz"] for end in BAR_ENDS)
        along = pd[second] - pd[first]
        pd[second] = pd[first] + along * self.spec.scale_bar.length / np.linalg.norm(along)
        return pd

    def parameter_group(self, name: str) -> tuple[str, str] | None:
        """A station's pose, or the placement robot_base."""
        return named_group(name, "station", "station {}'s pose") or super().parameter_group(name)

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

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        return {"azimuth": "angle", "elevation": "angle"}, {}

    def key_names(self, robot) -> dict[str, set[str]]:
        return {"station": set(self.spec.stations), "target": set(self.spec.targets) | set(BAR_ENDS if self.spec.scale_bar else ())}

    def pose_keys(self) -> list[Key]:
        return [(station, target) for station in self.spec.stations for target in self.spec.targets]

    def fixed_samples(self) -> list[Key]:
        """The scale bar's marks, sighted BAR_SIGHTINGS times from every station."""
        if self.spec.scale_bar is None:
            return []
        return [(station, end) for station in self.spec.stations for end in BAR_ENDS] * BAR_SIGHTINGS

    def pseudo_observations(self) -> dict[Key, tuple[float, ...]]:
        return {} if self.spec.scale_bar is None else {BAR_LENGTH: (self.spec.scale_bar.length,)}

