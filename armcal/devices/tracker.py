"""Laser tracker (or CMM, or any 3D point device): a target's position in the instrument frame.

A key is (target,), or (target, station) for a reading at a station. Readings:
x, y, z = scale * (P p) with P the robot base in the instrument frame; with
``orientation``, also rx, ry, rz, the intrinsic XYZ Euler angles of the target
frame in the instrument frame (R = Rx Ry Rz). P is ``robot_base`` for a reading at
no station, else its station's own frame (``station.<name>``): a robot whose base
is set up anew at each station, as a theodolite network has a frame per station;
each frame is the 6 parameters of Goswami's count (1) once more. A data file's
optional ``use`` column marks held-out rows that re-register a new station
(``register``) and those that are predicted (``evaluate``, the default).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from typing import ClassVar, Literal

from pydantic import Field

from armcal.devices.base import Channel, DeviceModel, Key, declared, named_group
from armcal.effects.effect_type import EffectType
from armcal.effects.library import EffectSpec
from armcal.effects.types.sensor_scale import SENSOR_SCALE
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, parameter_entry, pose_entries
from armcal.kinematics.transforms import POSE_FIELDS, pose_from_matrix, rigid_registration
from armcal.spec_parts.base import ScaleParam, SpecModel, declared_pose, fixed
from armcal.spec_parts.starter import mm, flange_point, random_poses
from armcal.spec_parts.instrument import ESTIMATE_HELP, GROUPS_HELP, AngleSigma, DeviceSpec, LengthSigma
from armcal.spec_parts.robot import Pose

POSITION = tuple(Channel(c, "length") for c in ("x", "y", "z"))
ORIENTATION = tuple(Channel(c, "angle") for c in ("rx", "ry", "rz"))
USES = ("register", "evaluate")  # the values of a data file's use column


class TrackerStation(SpecModel):
    """One set-up of the robot before the instrument: its base frame there."""

    robot_base: Pose = Field(description="the robot base frame in the instrument frame at this station (free: registered from the data)")


def intrinsic_xyz(R):
    """(rx, ry, rz) with R = Rot(x, rx) Rot(y, ry) Rot(z, rz); ry in [-pi/2, pi/2]."""
    rx = ca.atan2(-R[1, 2], R[2, 2])
    ry = ca.asin(ca.fmin(ca.fmax(R[0, 2], -1), 1))
    rz = ca.atan2(-R[0, 1], R[0, 0])
    return rx, ry, rz


class Tracker(DeviceSpec):
    """Laser tracker / CMM: 3D point (and optionally orientation) of a target."""

    type: Literal["tracker"]
    targets: list[str] = Field(min_length=1, description="names of robot targets measured")
    robot_base: Pose = Pose()
    stations: dict[str, TrackerStation] = Field(
        {}, description="the robot's set-ups, each with its own base frame; the data's station column names them"
    )
    noise: LengthSigma = Field(description="position noise sigma per coordinate, or auto (estimated from the data)")
    orientation: bool = Field(False, description="the data also hold the target's orientation rx, ry, rz")
    orientation_noise: AngleSigma | None = Field(None, description="orientation noise sigma (needed with orientation), or auto")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target"]] = Field(["kind"], description=GROUPS_HELP)
    scale: ScaleParam = fixed(1.0)

    def noise_fields(self) -> tuple[str, ...]:
        return ("noise", "orientation_noise") if self.orientation else ("noise",)

    def base_frame_free(self, free: set[str]) -> bool:
        """A free robot_base, or a free frame of any station: either identifies the placement with the robot."""
        return super().base_frame_free(free) or any(name.startswith("station.") for name in free)

    procedures: ClassVar[tuple[str, ...]] = ("poses", "circle_point")
    instrument_effects: ClassVar[tuple[EffectType, ...]] = (SENSOR_SCALE,)
    fixes_positions: ClassVar[bool] = True
    reads_positions: ClassVar[bool] = True
    locates_targets: ClassVar[bool] = True

    def sees_orientation(self) -> bool:
        return self.orientation

    def check(self, spec):
        yield from super().check(spec)
        if self.orientation and self.orientation_noise is None:
            yield ("device", "orientation_noise"), "a tracker that measures orientation needs orientation_noise (its sigma)"

    def parameter_location(self, name: str) -> list[str]:
        head, _, field = name.rpartition(".")
        if head.startswith("station."):
            return ["device", "stations", head.split(".", 1)[1], "robot_base", field]
        return ["device", "scale"] if name == "tracker.scale" else super().parameter_location(name)

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`\'s targets and sections (``dof`` joints, ``s`` times the PUMA 560\'s size): A tracker in front of the robot, facing it; random poses."""
        return [flange_point(dof, "reflector")], [
            "device:",
            "  type: tracker",
            "  targets: [reflector]",
            "  # Robot base in the tracker frame (placeholder: tracker in front of the robot, facing it);",
            "  # free, identified with the robot.",
            f"  robot_base: {{x: {mm(max(3000.0, 3000.0 * s))}, y: 0, z: 0, rz: 180, ry: 0, rx: 0}}",
            "  noise: 0.025   # mm, the tracker's stated 1-sigma",
            "procedure:",
            *random_poses(150, 1),
            "validation:",
            *random_poses(75, 2),
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        stations = [f"stations {', '.join(self.stations)}"] if self.stations else []
        return "laser tracker" + (" (position and orientation)" if self.orientation else ""), [f"targets {', '.join(self.targets)}", *stations]


def _frame(station: str | None) -> str:
    """The parameter prefix of the robot base frame readings at ``station`` are taken in."""
    return "robot_base" if station is None else f"station.{station}"


class TrackerModel(DeviceModel):
    type = "tracker"
    section = Tracker
    optional_key_columns = ("station",)

    def __init__(self, spec: Tracker):
        self.spec = spec
        entries = pose_entries("robot_base", declared_pose(spec.robot_base))
        entries.append(parameter_entry("tracker.scale", "scale", spec.scale.declared()))
        for name, station in spec.stations.items():
            entries += pose_entries(_frame(name), declared_pose(station.robot_base))
        self.parameters = ParameterSet(tuple(entries))

    def key_of(self, values: tuple) -> Key:
        """(target,) at no station, as without a station column; (target, station) at one."""
        return values if values[1] is not None else values[:1]

    def station(self, key: Key) -> str | None:
        return key[1] if len(key) > 1 else None

    def placed(self, key: Key) -> Key:
        return key[:1]

    def stations(self) -> tuple[str, ...]:
        return tuple(self.spec.stations)

    def parameter_group(self, name: str) -> tuple[str, str] | None:
        """A station's frame, or the placement robot_base."""
        return named_group(name, "station", "station {}'s pose") or super().parameter_group(name)

    def pose_keys(self) -> list[Key]:
        """Each target; with stations, each target at each station (every pose is read at every station)."""
        targets = self.spec.seen_targets()
        return [(t, s) for s in self.spec.stations for t in targets] if self.spec.stations else [(t,) for t in targets]

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return POSITION + (ORIENTATION if self.spec.orientation else ())

    def target(self, key: Key) -> str | None:
        return key[0]

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        seen = ca.mtimes(pose_from_symbols(sym, _frame(self.station(key))), pose)
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

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        return {c.name: c.kind for c in self.channels(())}, {"use": "text"}

    vocabulary_columns = ("use",)

    def key_names(self, robot) -> dict[str, set[str]]:
        """Targets as the spec names them; any station (held-out data may name new ones); use: register or evaluate."""
        return {**super().key_names(robot), "use": {"", *USES}}

    def candidate_effects(self, free: set[str]) -> list[EffectSpec]:
        return [] if "tracker.scale" in free else [EffectSpec(SENSOR_SCALE)]

    def registered(self, theta: np.ndarray, names: tuple[str, ...], free: set[str], kinematics, data) -> np.ndarray | None:
        """A free tracker-to-base transform, one per station, registered from the data: the rigid registration (Kabsch)
        of the target positions the robot part of ``theta`` predicts onto the measured ones, of the readings taken in
        that frame; components not ``free`` keep their values."""
        frames: dict[str, tuple[list, list]] = {}
        for key, rows in data.groups().items():
            nominal, measured = frames.setdefault(_frame(self.station(key)), ([], []))
            nominal.append(kinematics.target_poses(key[0], data.q[rows], theta[: len(kinematics.parameters)])[:, :3, 3])
            measured.append(np.stack([data.readings[c][rows] for c in "xyz"], axis=1))
        frames = {prefix: pair for prefix, pair in frames.items() if any(f"{prefix}.{f}" in free for f in POSE_FIELDS)}
        if not frames:
            return None
        registered = theta.copy()
        for prefix, (nominal, measured) in frames.items():
            for field, value in zip(POSE_FIELDS, pose_from_matrix(rigid_registration(np.concatenate(nominal), np.concatenate(measured)))):
                if f"{prefix}.{field}" in free:
                    registered[names.index(f"{prefix}.{field}")] = value
        return registered
