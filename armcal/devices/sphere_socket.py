"""Sphere in sockets: the tool's ball held in fixed kinematic sockets at many orientations; no external instrument.

A key is (socket,). At each recorded pose the ball's centre is the socket's centre, so the
readings are the contact's residuals, zero at every recorded pose (DeviceModel.contact):
(dx, dy, dz) = b(q) - s, b(q) the ball's centre in the robot base frame (the chain), s the
socket's centre (parameters socket.<name>.x/y/z). Goswami, Quaid & Peshkin's ball-bar with
its length held at zero, or Stone's point measurement (4.48) with the point known only to
be the same at every pose of a socket. Certified socket-to-socket distances, keys
("distance", a, b) with one reading |s_a - s_b| the spec gives, fix the scale.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from typing import ClassVar, Literal

from pydantic import Field

from armcal.devices.base import Channel, DeviceModel, Key, declared
from armcal.kinematics import ik
from armcal.kinematics.params import ParameterSet, point_entries
from armcal.spec_parts.base import Length, SpecModel, declared_points
from armcal.spec_parts.starter import flange_point, mm
from armcal.spec_parts.instrument import ESTIMATE_HELP, GROUPS_HELP, DeviceSpec, LengthSigma, Point

RESIDUALS = tuple(Channel(c, "length") for c in ("dx", "dy", "dz"))
DISTANCE = "distance"  # the first element of a certified distance's key
CONE = 60.0  # deg: half-angle of the cone about straight down that random approach directions fill


class CertifiedDistance(SpecModel):
    """A socket-to-socket distance from a calibration certificate (a socket plate's, a gauge's)."""

    between: tuple[str, str] = Field(description="the two sockets (names from device.sockets)")
    length: Length = Field(gt=0.0, description="certified centre-to-centre distance")
    noise: Length = Field(gt=0.0, description="its certificate's standard uncertainty")


class SphereSocket(DeviceSpec):
    """A ball on the robot held in fixed sockets (kinematic nests) at many orientations: no external instrument."""

    type: Literal["sphere_socket"]
    ball: str = Field(description="the robot target at the ball's centre (a precision sphere on the flange or tool)")
    sockets: dict[str, Point] = Field(min_length=1, description="socket centres in the robot base frame (free or fixed)")
    distances: list[CertifiedDistance] = Field([], description="certified socket-to-socket distances; without one the scale is not identifiable")
    noise: LengthSigma = Field(description="seating repeatability sigma per coordinate, or auto (estimated from the data)")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "socket"]] = Field(["kind"], description=GROUPS_HELP)

    locates_targets: ClassVar[bool] = True
    target_field: ClassVar[str] = "ball"
    held_out_metric: ClassVar[str] = "seating residual (ball centre minus socket centre)"

    def check(self, spec):
        """The ball must be a robot target; a certified distance must name two of the sockets."""
        yield from super().check(spec)
        for i, distance in enumerate(self.distances):
            for j, name in enumerate(distance.between):
                if name not in self.sockets:
                    yield ("device", "distances", i, "between", j), f"socket '{name}' is not in device.sockets ({', '.join(self.sockets)})"
            if distance.between[0] == distance.between[1]:
                yield ("device", "distances", i, "between"), "a certified distance is between two different sockets"
            first = next(j for j, d in enumerate(self.distances) if set(d.between) == set(distance.between))
            if first < i:
                yield ("device", "distances", i, "between"), f"the distance {'-'.join(distance.between)} is already certified as entry {first + 1}"

    def base_frame_free(self, free: set[str]) -> bool:
        """Free sockets absorb any rigid motion of the robot with them: its base frame is known up to one."""
        return super().base_frame_free(free) or any(name.startswith("socket.") for name in free)

    def parameter_location(self, name: str) -> list[str]:
        socket, _, field = name.split(".", 1)[1].rpartition(".")  # socket.<name>.<x|y|z>
        return ["device", "sockets", socket, field]

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`\'s targets and sections (``dof`` joints, ``s`` times the PUMA 560\'s size): a ball on the flange,
        four sockets in front of the robot, two of them raised, one certified distance; random poses."""
        # two sockets on a riser: sockets in one plane leave a flat direction on a large arm (docs/robots.md)
        sockets = [(350.0, -150.0, 0.0), (350.0, 150.0, 150.0), (500.0, -150.0, 150.0), (500.0, 150.0, 0.0)]
        return [flange_point(dof, "ball", x=40.0, z=80.0)], [
            "device:",
            "  type: sphere_socket",
            "  ball: ball",
            "  # Four sockets (kinematic nests) in front of the robot, two on a riser, robot base frame (placeholders:",
            "  # free, identified with the robot; not all in one plane).",
            "  sockets:",
            *(f"    socket{i}: {{x: {mm(x * s)}, y: {mm(y * s)}, z: {mm(z * s)}}}" for i, (x, y, z) in enumerate(sockets, 1)),
            "  distances:   # from the socket plate's certificate: they fix the scale",
            f"    - {{between: [socket1, socket4], length: {mm(np.hypot(150.0, 300.0) * s)}, noise: 0.002}}",
            "  noise: 0.005   # mm, the seating repeatability per coordinate",
            "procedure:",
            "  type: poses",
            "  count: 200   # random sockets and approach directions (within 60 deg of straight down)",
            "  seed: 1",
            "validation:",
            "  type: poses",
            "  count: 100",
            "  seed: 2",
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        n = len(self.distances)
        certified = [f"{'-'.join(d.between)} {length(d.length)} (u = {length(d.noise)})" for d in self.distances]
        return (f"ball in {len(self.sockets)} fixed sockets" + (f", {n} certified distance{'s' if n > 1 else ''}" if n else ""),
                [f"ball: robot target {self.ball}", f"sockets {', '.join(self.sockets)}", *([f"certified {', '.join(certified)}"] if n else [])])


def _certified(key: Key) -> bool:
    """Whether a key is a certified distance's, ("distance", a, b), rather than a socket's, (socket,)."""
    return len(key) == 3 and key[0] == DISTANCE


class SphereSocketModel(DeviceModel):
    type = "sphere_socket"
    section = SphereSocket
    key_columns = ("socket",)
    keyed_poses = True
    contact = True

    def __init__(self, spec: SphereSocket):
        self.spec = spec
        self.parameters = ParameterSet(tuple(point_entries("socket", declared_points(spec.sockets))))

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return (Channel("length", "length"),) if _certified(key) else RESIDUALS

    def target(self, key: Key) -> str | None:
        return None if _certified(key) else self.spec.ball

    def socket(self, name: str, sym: dict) -> ca.SX:
        return ca.vertcat(*(sym[f"socket.{name}.{c}"] for c in "xyz"))

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        if _certified(key):
            return ca.norm_2(self.socket(key[2], sym) - self.socket(key[1], sym))
        return pose[:3, 3] - self.socket(key[0], sym)

    def pseudo_observations(self) -> dict[Key, tuple[float, ...]]:
        return {(DISTANCE, *d.between): (d.length,) for d in self.spec.distances}

    def distance(self, key: Key) -> CertifiedDistance:
        return next(d for d in self.spec.distances if tuple(d.between) == key[1:])

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        shape = np.shape(np.atleast_2d(readings))
        return np.full(shape, self.distance(key).noise if _certified(key) else declared(self.spec.noise))

    def noise_field(self, key: Key, channel: str) -> str | None:
        return None if _certified(key) else "noise"  # a certified distance is its certificate's, never estimated

    def noise_kind(self, field: str) -> str:
        return "seating"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        return {"socket": key[0]}

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        return {}, {}  # a contact: the data hold no readings (prepare adds the zeros)

    def key_names(self, robot) -> dict[str, set[str]]:
        return {"socket": set(self.spec.sockets)}

    def centre(self, key: Key, values: dict[str, float]) -> np.ndarray | None:
        return None  # the ball sits at the socket: no longitude about it to show

    def true_parameters(self, pd: np.ndarray) -> np.ndarray:
        """Sockets moved least (minimum-norm Gauss-Newton over their free coordinates) to be at their certified
        distances: a simulated socket plate true to its certificate."""
        pd = np.asarray(pd, dtype=float).copy()
        if not self.spec.distances:
            return pd
        index = {name: [self.parameters.index(f"socket.{name}.{c}") for c in "xyz"] for name in self.spec.sockets}
        free = self.parameters.free
        for _ in range(20):
            r, J = np.zeros(len(self.spec.distances)), np.zeros((len(self.spec.distances), len(pd)))
            for k, d in enumerate(self.spec.distances):
                a, b = (index[n] for n in d.between)
                along = pd[b] - pd[a]
                r[k] = np.linalg.norm(along) - d.length
                J[k, b], J[k, a] = along / np.linalg.norm(along), -along / np.linalg.norm(along)
            if np.max(np.abs(r)) < 1e-12:
                break
            J[:, ~free] = 0.0
            pd -= np.linalg.pinv(J) @ r
        return pd

    def random_keyed_poses(self, spec, kinematics, count: int, rng: np.random.Generator) -> tuple[np.ndarray, list[Key], dict[str, int]]:
        """``count`` random seatings: a socket at random, the flange's z axis (the approach) in a random direction
        within CONE of straight down (uniform over that spherical cap), the rotation about it left to the inverse
        kinematics of the nominal model (Stone 5.4, several starts) within the joint limits."""
        values = self.parameters.values(self.parameters.nominal)
        names = list(self.spec.sockets)
        chosen = rng.integers(len(names), size=count)
        cos_tilt = rng.uniform(np.cos(np.radians(CONE)), 1.0, count)
        azimuth = rng.uniform(0.0, 2 * np.pi, count)
        sin_tilt = np.sqrt(1.0 - cos_tilt**2)
        axes = np.stack([sin_tilt * np.cos(azimuth), sin_tilt * np.sin(azimuth), -cos_tilt], axis=1)
        centres = np.array([[values[f"socket.{names[k]}.{c}"] for c in "xyz"] for k in chosen]).reshape(count, 3)
        goals = np.concatenate([centres, axes], axis=1)
        Q = ik.solve_from_starts(kinematics, goals, frame=self.spec.ball, seed=int(rng.integers(2**31)))
        return Q, [(names[k],) for k in chosen], {}
