"""Touch probe on planes: a ball on the robot touches the faces of a datum cube or fixture planes; no instrument reads.

A key is (plane,). At each recorded pose the probe ball touches the plane, so the
one reading - the signed distance of the ball's centre from the plane minus the
ball's radius - is zero (a contact, ``DeviceModel.contact``): the data files hold
the joint values and the plane only. In the planes' frame (a datum cube's frame)
the plane is {x : n . x = d}, n its unit normal pointing out of the material
towards the probe, d its offset; the robot base sits there at P (robot_base):

    contact = n(tilt1, tilt2) . (P s(q)) - d - radius        s(q): the ball centre in the robot base frame

Stone's plane in normal form, (4.6)-(4.7), whose error function is the signed
perpendicular distance for a unit normal, seen through the base transform P of
(4.48); one scalar reading per pose, partial pose information as with Goswami's
ball-bar (G, "Pose Measurements: How Many Dimensions Are Enough?").
The nominal normal n0 is turned by tilt1 about u1 and tilt2 about u2, two unit
axes square to it: u2 = n0 x e / |n0 x e| (e the coordinate axis most nearly
square to n0, the first of a tie), u1 = u2 x n0, so that (u1, u2, n0) is right-handed and
n = Rot(u1, tilt1) Rot(u2, tilt2) n0 = sin(tilt2) u1 + cos(tilt2) (cos(tilt1) n0 - sin(tilt1) u2).
A tilt turns the plane about the foot of the perpendicular from the frame's origin
(to first order), a cube's face about its centre when the frame is the cube's.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from typing import ClassVar, Literal

from pydantic import Field, field_validator

from armcal.devices.base import Channel, DeviceModel, Key, declared
from armcal.kinematics import ik
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, parameter_entry, parameter_set, pose_entries
from armcal.spec_parts.base import AngleParam, Length, LengthParam, Number, SpecModel, declared_pose, fixed
from armcal.spec_parts.instrument import ESTIMATE_HELP, GROUPS_HELP, DeviceSpec, LengthSigma
from armcal.spec_parts.robot import Pose
from armcal.spec_parts.starter import flange_point, mm, random_poses

CONTACT = (Channel("contact", "length"),)
PLANE_FIELDS = ("offset", "tilt1", "tilt2")
SCALE_TOLERANCE = 1e-9  # relative residual of the held planes' common point above which they have none
CONE = np.radians(30.0)  # half-angle of the cone about the normal that random approach directions lie in


class Plane(SpecModel):
    """A plane the probe touches: {x : n . x = offset} in the planes' frame, n its normal turned by two small tilts."""

    normal: tuple[Number, Number, Number] = Field(
        description="nominal normal, planes' frame, pointing out of the material towards the probe (normalised on load)"
    )
    offset: LengthParam = Field(description="the plane's distance from the frame's origin along its normal: {x : n . x = offset}")
    tilt1: AngleParam = Field(fixed(0.0), description="turn of the normal about u1 = u2 x normal (left out: held at 0)")
    tilt2: AngleParam = Field(fixed(0.0), description="turn of the normal about u2, square to the normal and the coordinate axis most nearly square to it (left out: held at 0)")
    patch: Length = Field(50.0, gt=0.0, description="side of the square about the foot of the normal (offset * normal) where random touches are planned")

    @field_validator("normal")
    @classmethod
    def _unit(cls, normal: tuple[float, float, float]) -> tuple[float, float, float]:
        length = float(np.linalg.norm(normal))
        if not length > 0:
            raise ValueError("a plane's normal must not be zero: give the direction out of the material, e.g. [0, 0, 1]")
        return tuple(float(c) / length for c in normal)

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u1, u2, n0): the axes the tilts turn the normal about, and the nominal normal; right-handed."""
        n0 = np.array(self.normal)
        e = np.eye(3)[int(np.argmin(np.abs(n0)))]
        u2 = np.cross(n0, e)
        u2 /= np.linalg.norm(u2)
        return np.cross(u2, n0), u2, n0


def tilted_normal(plane: Plane, tilt1, tilt2, symbolic: bool = False):
    """n = Rot(u1, tilt1) Rot(u2, tilt2) n0, of numbers (numpy) or of CasADi symbols."""
    u1, u2, n0 = (ca.DM(u) for u in plane.axes()) if symbolic else plane.axes()
    cos, sin = (ca.cos, ca.sin) if symbolic else (np.cos, np.sin)
    return sin(tilt2) * u1 + cos(tilt2) * (cos(tilt1) * n0 - sin(tilt1) * u2)


def _holds_a_length(robot) -> bool:
    """Whether the spec holds a nonzero length of the robot's chain, tool or targets (a scale the fit keeps)."""
    return any(e.kind == "length" and not e.free and not e.reason and e.nominal != 0 for e in parameter_set(robot.chain()).entries)


class PlaneContact(DeviceSpec):
    """Touch probe on planes: a ball on the robot touches known or free planes (a datum cube's faces); the joint
    values are recorded at each touch."""

    type: Literal["plane_contact"]
    probe: str = Field(description="the robot target at the probe ball's centre")
    radius: Length = Field(gt=0.0, description="the probe ball's radius")
    planes: dict[str, Plane] = Field(min_length=1, description="the planes touched, by name (planes' frame: e.g. the datum cube's)")
    robot_base: Pose = Field(Pose(), description="the robot base frame in the planes' frame")
    noise: LengthSigma = Field(description="the touch's repeatability: sigma of the ball's distance from the plane at the trigger, or auto")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "plane"]] = Field(["kind"], description=GROUPS_HELP)

    procedures: ClassVar[tuple[str, ...]] = ("poses",)
    target_field: ClassVar[str] = "probe"
    held_out_metric: ClassVar[str] = "contact residual (the ball's distance from the plane it touches)"

    def check(self, spec):
        yield from super().check(spec)
        base_free = any(getattr(self.robot_base, f).vary for f in ("x", "y", "z", "rx", "ry", "rz"))
        if base_free and all(getattr(plane, f).vary for plane in self.planes.values() for f in PLANE_FIELDS):
            yield ("device", "robot_base"), (
                "every plane is free, so the planes carry the robot base's pose (the robot and the planes moved together "
                "change no contact): hold robot_base (vary: false), or hold a plane known in the planes' frame"
            )

        if not self.fixes_scale() and not _holds_a_length(spec.robot):
            yield ("device", "planes"), (
                "nothing fixes the length scale: the ball-centre planes of the planes whose offsets are held meet in a "
                "point (or no offset is held) and no length of the robot is held, so the robot shrunk about that point, "
                "the free planes with it, touches the same way, and a fit shrinks the robot towards it; hold the offsets "
                "of two parallel planes (opposite faces of a cube of certified size) or a length you know (the probe's)"
            )

    def fixes_scale(self) -> bool:
        """Whether the planes fix the length scale: the ball-centre planes {n . x = offset + radius} of those whose
        offsets are held have no common point (a scaling about a common point would keep every one of them)."""
        held = [plane for plane in self.planes.values() if not plane.offset.vary]
        if not held:
            return False
        N = np.array([plane.normal for plane in held])
        d = np.array([plane.offset.value + self.radius for plane in held])
        centre = np.linalg.lstsq(N, d, rcond=None)[0]
        return bool(np.max(np.abs(N @ centre - d)) > SCALE_TOLERANCE * max(1.0, np.max(np.abs(d))))

    def base_frame_free(self, free: set[str]) -> bool:
        """Free planes absorb a rigid motion of the robot with them (along or about their normals): its base frame is
        then known up to one, as with a free robot_base."""
        return super().base_frame_free(free) or any(name.startswith("plane.") for name in free)

    def parameter_location(self, name: str) -> list[str]:
        if name.startswith("plane."):
            _, plane, field = name.split(".")
            return ["device", "planes", plane, field]
        return super().parameter_location(name)

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`'s targets and sections (``dof`` joints, ``s`` times the PUMA 560's size): a ball probe on the
        flange, a datum cube's five accessible faces (known) in front of the robot, the robot base free in the cube's frame."""
        # a 150 mm cube left the KR 6 R900 a flat direction; its back face stays no farther than before (docs/robots.md)
        half, ahead = 150.0 * s, 375.0 * s
        faces = {"front": (-1, 0, 0), "back": (1, 0, 0), "left": (0, 1, 0), "right": (0, -1, 0), "top": (0, 0, 1)}
        return [flange_point(dof, "probe")], [
            "device:",
            "  type: plane_contact",
            "  probe: probe",
            "  radius: 3   # mm, the probe ball's radius (from the stylus' certificate)",
            f"  # A datum cube of {mm(2 * half)} mm in front of the robot, its frame at the cube's centre (placeholders:",
            "  # the faces' offsets from the cube's certificate, held); normals point out of the cube.",
            "  planes:",
            *(f"    {name}: {{normal: [{', '.join(map(str, n))}], offset: {{value: {mm(half)}, vary: false}}, patch: {mm(half)}}}"
              for name, n in faces.items()),
            "  # The robot base in the cube's frame (placeholder: the cube on the robot's mounting surface);",
            "  # free, identified with the robot.",
            f"  robot_base: {{x: {mm(-ahead)}, y: 0, z: {mm(-half)}, rz: 0, ry: 0, rx: 0}}",
            "  noise: 0.01   # mm: the touch's repeatability (trigger and the robot's latching of its joints)",
            "procedure:",
            *random_poses(960, 1),
            "validation:",
            *random_poses(120, 2),
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        known = [name for name, plane in self.planes.items() if not any(getattr(plane, f).vary for f in PLANE_FIELDS)]
        held = "all known" if len(known) == len(self.planes) else f"known: {', '.join(known)}" if known else "all fitted"
        return f"touch probe on planes, ball radius {length(self.radius)}", [f"probe {self.probe}", f"planes {', '.join(self.planes)} ({held})"]


class PlaneContactModel(DeviceModel):
    type = "plane_contact"
    section = PlaneContact
    key_columns = ("plane",)
    keyed_poses = True
    contact = True

    def __init__(self, spec: PlaneContact):
        self.spec = spec
        entries = pose_entries("robot_base", declared_pose(spec.robot_base))
        for name, plane in spec.planes.items():
            entries += [parameter_entry(f"plane.{name}.{f}", "length" if f == "offset" else "angle", getattr(plane, f).declared()) for f in PLANE_FIELDS]
        self.parameters = ParameterSet(tuple(entries))

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return CONTACT

    def target(self, key: Key) -> str | None:
        return self.spec.probe

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        """contact = n . (P s) - d - radius: the ball centre's signed distance from the plane minus the radius."""
        name = key[0]
        seen = ca.mtimes(pose_from_symbols(sym, "robot_base"), pose)
        normal = tilted_normal(self.spec.planes[name], sym[f"plane.{name}.tilt1"], sym[f"plane.{name}.tilt2"], symbolic=True)
        return ca.dot(normal, seen[:3, 3]) - sym[f"plane.{name}.offset"] - self.spec.radius

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        return np.full(np.shape(np.atleast_2d(readings)), declared(self.spec.noise))

    def noise_kind(self, field: str) -> str:
        return "contact"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        return {"plane": key[0]}

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        return {}, {}  # a contact: its readings are the zeros prepare adds

    def key_names(self, robot) -> dict[str, set[str]]:
        return {"plane": set(self.spec.planes)}

    def random_keyed_poses(self, spec, kinematics, count: int, rng: np.random.Generator) -> tuple[np.ndarray, list[Key], dict[str, int]]:
        """Random touches: a plane at random, a point on its patch (a square of side ``patch`` about the foot of its
        normal), the ball's centre ``radius`` off the plane along its normal, the flange's z axis (the probe's
        approach) within CONE of the inward normal; each solved by the nominal model's inverse kinematics (Stone 5.4,
        several starts) within the joint limits."""
        values = self.parameters.values(self.parameters.nominal)
        base = np.linalg.inv(np.asarray(pose_from_symbols(values, "robot_base"), dtype=float))  # planes' frame -> robot base
        names = list(self.spec.planes)
        chosen = rng.integers(len(names), size=count)
        goals, keys = np.zeros((count, 6)), []
        for i in range(count):
            name = names[chosen[i]]
            plane = self.spec.planes[name]
            u1, u2, n0 = plane.axes()
            n = tilted_normal(plane, values[f"plane.{name}.tilt1"], values[f"plane.{name}.tilt2"])
            a, b = rng.uniform(-plane.patch / 2, plane.patch / 2, 2)
            point = values[f"plane.{name}.offset"] * n0 + a * u1 + b * u2
            centre = point + (values[f"plane.{name}.offset"] + self.spec.radius - n @ point) * n
            cos_angle, turn = rng.uniform(np.cos(CONE), 1.0), rng.uniform(0.0, 2 * np.pi)
            approach = -(cos_angle * n + np.sqrt(1 - cos_angle**2) * (np.cos(turn) * u1 + np.sin(turn) * u2))
            goals[i] = [*(base[:3, :3] @ centre + base[:3, 3]), *(base[:3, :3] @ approach)]
            keys.append((name,))
        Q = ik.solve_from_starts(kinematics, goals, frame=self.spec.probe, seed=int(rng.integers(2**31)))
        return Q, keys, {}
