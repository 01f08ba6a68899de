"""What every instrument's model provides: its readings of a measured pose, its data files, noise and simulation.

A device model maps the pose of a measured point in the robot base frame and
the device parameters to readings: g(T, p_device). Samples are grouped by a
key (which target, pivot, station...); h(q, p_robot, p_device) = g(fk(q, p_robot), p_device)
is one CasADi Function per key (composed, with the effects, in model/measurement.py only),
evaluated for all samples of the key at once.

A reading's sigma is the device's noise model (``noise_sigma``) times the factor
of its noise group where the noise was estimated from the data
(identify/variance.py, ``with_noise_scale``). A group is the spec field that
declares the reading's noise (its kind: positions, orientations...) and, as
``noise_groups`` asks, its target, station, ball-bar pairing or microphone.
A noise declared ``auto`` is the unit of its kind (1 mm, 1 rad) times its
group's factor, so it has no value until it is estimated.
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from functools import cache
from types import MappingProxyType

import casadi as ca
import numpy as np

from armcal.support.errors import UserError
from armcal.kinematics.params import ParameterSet

Key = tuple[str | None, ...]


@dataclass(frozen=True)
class Channel:
    """One reading of a sample: its CSV column and kind (length or angle)."""

    name: str
    kind: str


class DeviceModel(ABC):
    """A measuring instrument as a function of the measured pose and its own parameters.

    It is everything the rest of armcal knows of an instrument: its measurement
    model, its data files' columns, the keys a pose is read on, its description,
    the effects on its side the diagnosis may propose, and where a fit starts.
    The defaults are those of an instrument that reads robot targets by name.
    """

    type: str  # the spec's device.type
    section: type  # the pydantic model of its spec section (a spec_parts.instrument.DeviceSpec)
    parameters: ParameterSet
    spec: object  # the device section of the spec

    @classmethod
    def from_spec(cls, spec, mode: str | None) -> "DeviceModel":
        """The model of ``spec``'s device; ``mode``: which readings it fits where it offers a choice (None: as its
        section says)."""
        return cls(spec.device)

    @staticmethod
    def readings_mode(header: list[str], requested: str | None) -> str | None:
        """The readings a data file with this header holds, where the instrument offers a choice."""
        return requested

    # Its data files (the CSV contract of docs/architecture.md)
    key_columns: tuple[str, ...] = ("target",)  # text columns that make a sample's key
    optional_key_columns: tuple[str, ...] = ()  # key columns a file may leave out or empty (None in the key)
    keyed_poses: bool = False  # each pose is read on one key, which pose lists name; else on every pose_keys()

    @abstractmethod
    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        """Required and optional reading columns -> kind (length, angle) of a data file with this header."""

    def key_of(self, values: tuple) -> Key:
        """A sample's key from its key columns' values, the optional ones None where left empty."""
        return values

    def key_names(self, robot) -> dict[str, set[str]]:
        """The names each key column accepts (the empty string: an optional column left empty): by default the targets
        it measures, or any robot target when its section names none (a sonic digitizer's sparkers)."""
        return {"target": set(self.spec.seen_targets() or robot.targets)}

    def target_aliases(self, robot) -> dict[str, str]:
        """Other names data files may give a target (e.g. the link that carries it) -> its name."""
        return {}

    off_robot_targets: tuple[str, ...] = ()  # names in a target column that are not on the robot (no joint values)
    vocabulary_columns: tuple[str, ...] = ()  # key columns whose values are armcal's words, not names the spec gives

    # Its set-ups: a station with a frame of its own (a tracker before a robot set up anew at each)
    def station(self, key: Key) -> str | None:
        """The station a key's readings were taken at; None: the instrument's one placement (robot_base)."""
        return None

    def placed(self, key: Key) -> Key:
        """The same readings taken in the instrument's one placement (robot_base) instead of at a station."""
        return key

    def stations(self) -> tuple[str, ...]:
        """The stations whose frames are parameters of the model (the spec declares them)."""
        return ()

    def parameter_group(self, name: str) -> tuple[str, str] | None:
        """The group one of its parameters is freed with and the group's label, e.g. ("pivot.p1", "pivot p1's
        position"); None: a parameter on its own. Here: the instrument's one placement, robot_base."""
        return ("robot_base", "the robot's pose in the instrument frame") if name.startswith("robot_base.") else None

    def pose_keys(self) -> list[Key]:
        """The keys read at every pose of a pose list."""
        return [(target,) for target in self.spec.seen_targets()]

    def random_keyed_poses(self, spec, kinematics, count: int, rng: np.random.Generator) -> tuple[np.ndarray, list[Key], dict[str, int]]:
        """For an instrument that reads each pose on one key (keyed_poses): ``count`` random poses where the nominal
        robot puts its target for a key to read (inverse kinematics), NaN rows where none was found; their keys; and
        the poses dropped before solving, by reason."""
        raise NotImplementedError(f"a {self.type} reads every pose on each of its keys")

    def fixed_samples(self) -> list[Key]:
        """Keys a pose list adds, read with no robot pose (e.g. a theodolite's scale-bar marks)."""
        return []

    def pseudo_observations(self) -> dict[Key, tuple[float, ...]]:
        """Readings the spec gives rather than the data, by key (e.g. a scale bar's certified length)."""
        return {}

    # The effects on its side, and where a fit starts
    def candidate_effects(self, free: set[str]) -> list:
        """The instrument-side effects the diagnosis may propose (EffectSpec), given the free parameters."""
        return []

    def registered(self, theta: np.ndarray, names: tuple[str, ...], free: set[str], kinematics, data) -> np.ndarray | None:
        """The parameter vector ``theta`` with its free placement registered from the data, where the instrument
        can stand far from its nominal placement; None: the nominal values are the start."""
        return None

    def centre(self, key: Key, values: dict[str, float]) -> np.ndarray | None:
        """The fixed point a key's readings are taken from (a ball-bar's pivot), at parameter ``values``; None if none."""
        return None

    def reach(self, key: Key) -> float | None:
        """The distance from its centre at which a key reads best (a ball-bar's mid-travel length); None if no centre."""
        return None

    # Its simulation
    def true_parameters(self, pd: np.ndarray) -> np.ndarray:
        """A simulated instrument's true parameters from drawn ones (e.g. a scale bar true to its certificate)."""
        return pd

    def simulated_readings(self, key: Key, values: np.ndarray, poses: np.ndarray, pd: np.ndarray, settings, rng) -> tuple:
        """What the simulated instrument reads from the noise-free ``values`` (N, channels) of the true ``poses``:
        (readings, which of them it can read, further columns it records). Here: its noise model's Gaussian noise
        (``settings.noise``, times ``noise_factor``); a reading the noise carried out of range is lost."""
        readable = np.ones(len(values), dtype=bool)
        if not settings.noise:
            return values, readable, {}
        values = values + rng.normal(size=values.shape) * self.sigma(key, values) * settings.noise_factor
        return values, self.measurable(key, values) if self.target(key) is not None else readable, {}

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
        readings = self.readings(key, pose, self.parameters.symbols(pd))
        return ca.Function(f"g_{self.type}", [pose, pd], [readings], ["T", "pd"], ["y"])

    noise_scale: MappingProxyType = MappingProxyType({})  # noise group -> factor on noise_sigma, estimated from the data

    @abstractmethod
    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Standard deviation of each reading (N, channels) from the spec's noise model (auto: 1 mm or 1 rad)."""

    def sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Standard deviation of each reading (N, channels): the noise model, times the estimated factor of its group."""
        sigma = np.array(self.noise_sigma(key, readings), dtype=float)
        if not self.noise_scale and "auto" not in (getattr(self.spec, f) for f in self.spec.noise_fields()):
            return sigma  # every sigma as the spec declares it
        for c, channel in enumerate(self.channels(key)):
            group = self.noise_group(key, channel.name)
            if group in self.noise_scale:
                sigma[:, c] *= self.noise_scale[group]
            elif group is not None and getattr(self.spec, self.noise_field(key, channel.name)) == "auto":
                raise UserError(
                    f"the {self.noise_field(key, channel.name)} of {group!r} readings is auto: it has no value until it is "
                    "estimated from the data (`armcal run`); declare a value to simulate or study with it"
                )
        return sigma

    def noise_field(self, key: Key, channel: str) -> str | None:
        """The spec field that declares this reading's noise (None: a spec pseudo-observation, never estimated)."""
        return "noise"

    def noise_kind(self, field: str) -> str:
        """How a noise field's readings are named in a group: position, orientation, angle, length, range."""
        return "length"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        """What this reading can be grouped by besides its kind (target, station, pairing, microphone)."""
        target = self.target(key)
        return {"target": target} if target is not None else {}

    def noise_group(self, key: Key, channel: str) -> str | None:
        """The name of a reading's noise group under the spec's noise_groups, e.g. "position, target tmac"."""
        field = self.noise_field(key, channel)
        if field is None:
            return None
        keys = self.noise_keys(key, channel)
        parts = [f"{name} {keys[name]}" for name in getattr(self.spec, "noise_groups", ("kind",)) if name != "kind" and name in keys]
        return ", ".join([self.noise_kind(field), *parts])

    def with_noise_scale(self, scale: dict[str, float]) -> "DeviceModel":
        """The same instrument, its readings' sigmas scaled by group (the noise estimated from the data)."""
        scaled = copy.copy(self)
        scaled.noise_scale = MappingProxyType(dict(scale))
        return scaled

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

    contact: bool = False  # its readings are a contact's residuals (a ball in its socket): zero at every recorded pose

    def prepare(self, measurements):
        """Readings as the model predicts them: a contact's zeros (its data files hold none); unchanged by default."""
        if not self.contact:
            return measurements
        zeros = {c.name: np.zeros(len(measurements.q)) for key in dict.fromkeys(measurements.keys) for c in self.channels(key)}
        return replace(measurements, readings={**zeros, **measurements.readings})

    def visible(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """Which true target poses (N, 4, 4) give a valid reading (N,)."""
        return self.measurable(key, self.evaluate(key, poses, pd))

    def evaluate(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """Readings (N, channels) for given target poses (N, 4, 4), e.g. of a simulated true robot."""
        pd = self.parameters.nominal if pd is None else np.asarray(pd, dtype=float)
        poses = np.asarray(poses, dtype=float)
        if len(poses) == 0:
            return np.zeros((0, len(self.channels(key))))
        side_by_side = poses.transpose(1, 0, 2).reshape(4, 4 * len(poses))
        return np.array(self.geometry(key).map(len(poses))(side_by_side, pd)).T


CONTACT_TOLERANCE = 1e-9  # mm (or rad): a contact's residual the solved joint values leave
CONTACT_STEP = 1e-6  # rad (or mm): the central-difference step of the contact's joint Jacobian


def held_in_contact(read, Q: np.ndarray, offset: np.ndarray, limits: np.ndarray, iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """The joint values nearest ``Q`` (N, n) at which a robot holds its contact (a ball in its socket) up to ``offset``
    (N, channels: a simulated seating's noise): ``read(Q)``, the contact's readings (N, channels), equal the offset. Gauss-Newton
    steps of minimum norm in joint space (the robot is moved no further than the contact needs); and which solved
    within the joint limits."""
    Q = np.array(Q, dtype=float)
    step = CONTACT_STEP * np.eye(Q.shape[1])
    for _ in range(iterations):
        r = read(Q) - offset
        if np.max(np.abs(r), initial=0.0) < CONTACT_TOLERANCE:
            break
        J = np.stack([(read(Q + h) - read(Q - h)) / (2 * CONTACT_STEP) for h in step], axis=2)  # (N, c, n)
        Q = Q - np.einsum("nij,nj->ni", np.linalg.pinv(J), r)
    held = np.all(np.abs(read(Q) - offset) < 1e3 * CONTACT_TOLERANCE, axis=1)
    return Q, held & np.all((Q >= limits[:, 0]) & (Q <= limits[:, 1]), axis=1)


def named_group(name: str, prefix: str, label: str) -> tuple[str, str] | None:
    """The group ``prefix.<part>`` of a parameter ``prefix.<part>.<field>`` and its ``label`` with the part in its {};
    None for a parameter without that prefix."""
    head = name.rpartition(".")[0]
    return (head, label.format(head.split(".", 1)[1])) if name.startswith(f"{prefix}.") else None


def declared(sigma: float | str) -> float:
    """A noise field's sigma in internal units; auto is the unit (1 mm, 1 rad) its group's estimated factor multiplies."""
    return 1.0 if sigma == "auto" else float(sigma)


def position(pose: ca.SX) -> ca.SX:
    """The translation column of a 4x4 pose."""
    return pose[:3, 3]


def transform_point(frame, point):
    """frame (4x4) applied to a 3-vector."""
    return ca.mtimes(frame[:3, :3], point) + frame[:3, 3]
