"""Telescopic ball-bar: centre-to-centre length from a fixed pivot to a sphere on the robot (Goswami).

A key is (pivot, sphere, extension rod or None). The instrument reports its
nominal length plus the LVDT displacement, so a bar whose true length differs
from the nominal by delta reads the distance minus delta: y = |s - p| + L0 - L.
Only lengths within the LVDT travel around the bar's mid-travel length are readable.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from typing import ClassVar, Literal

from pydantic import Field

from armcal.devices.base import Channel, DeviceModel, Key, declared, named_group
from armcal.effects.effect_type import EffectType
from armcal.effects.library import EffectSpec
from armcal.kinematics import ik
from armcal.kinematics.params import ParameterSet, parameter_entry, point_entries
from armcal.kinematics.transforms import on_sphere
from armcal.spec_parts.base import Length, LengthParam, Parameter, SpecModel, declared_points
from armcal.spec_parts.robot import Offset
from armcal.spec_parts.starter import mm
from armcal.spec_parts.instrument import ESTIMATE_HELP, GROUPS_HELP, DeviceSpec, LengthSigma, Point


DEFAULT_LATITUDES = (10.0, 85.0)  # degrees above a pivot, where the spec has no shells to take the range from
TRAVEL_USED = 0.8  # of the LVDT travel that random bar lengths spread over (mid-travel +- 40 %)
TILT = 0.3  # random tilt of a random pose's sphere axis about the shells' axis (norm of a normal perturbation)
TRAVEL_KEYS = "device.travel, device.length (the reading must stay within travel/2 of mid-travel)"


class BallbarLength(SpecModel):
    """An offset of the ball-bar's length."""

    type: Literal["ballbar_length"]
    offset: LengthParam = Parameter(value=0.0)


class BallbarLengthType(EffectType):
    """ballbar_length: an offset added to every length reading."""

    name = "ballbar_length"
    spec_model = BallbarLength

    def fields(self, effect):
        return [("offset", "length")]

    def reading(self, effect, channel, reading, value):
        return reading + value("offset")


BALLBAR_LENGTH = BallbarLengthType()


class PivotOffset(Offset):
    """A displacement of one ball-bar pivot."""

    type: Literal["pivot_offset"]
    x: LengthParam = Parameter(value=0.0)
    y: LengthParam = Parameter(value=0.0)
    z: LengthParam = Parameter(value=0.0)
    pivot: str = Field(description="the pivot that moved (from device.pivots)")


class PivotOffsetType(EffectType):
    """pivot_offset: a displacement of one pivot, added to its position pivot.<name>.x, y, z."""

    name = "pivot_offset"
    spec_model = PivotOffset
    part_key = "pivot"

    def fields(self, effect):
        return [("x", "length"), ("y", "length"), ("z", "length")]

    def device_shift(self, effect, parameters, value):
        return {parameters.index(f"pivot.{effect.part}.{c}"): value(c) for c in "xyz"}


PIVOT_OFFSET = PivotOffsetType()


class BallBar(DeviceSpec):
    """Telescopic ball-bar between a fixed pivot and a sphere on the robot (Goswami)."""

    type: Literal["ballbar"]
    pivots: dict[str, Point] = Field(min_length=1, description="magnetic chucks of the base fixture (world frame)")
    spheres: list[str] = Field(min_length=1, description="names of robot targets that carry a sphere")
    length: LengthParam = Field(description="centre-to-centre length at mid-travel, without extension rods")
    extension_rods: dict[str, Length] = Field({}, description="extension rods by name and length (Goswami's 46/61 cm bars)")
    travel: Length = Field(gt=0.0, description="LVDT travel (7.5 cm in Goswami)")
    noise: LengthSigma = Field(description="length noise sigma, or auto (estimated from the data)")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target", "pairing"]] = Field(["kind"], description=GROUPS_HELP)

    procedures: ClassVar[tuple[str, ...]] = ("shells", "poses")
    instrument_effects: ClassVar[tuple[EffectType, ...]] = (BALLBAR_LENGTH, PIVOT_OFFSET)
    target_field: ClassVar[str] = "spheres"
    held_out_metric: ClassVar[str] = "bar-length error"

    def check_procedure(self, procedure, loc):
        yield from super().check_procedure(procedure, loc)
        if procedure.type != "shells":
            return
        for i, pairing in enumerate(procedure.pairings):
            if pairing.pivot not in self.pivots:
                yield (*loc, "pairings", i, "pivot"), f"pivot '{pairing.pivot}' is not in device.pivots"
            if pairing.sphere not in self.spheres:
                yield (*loc, "pairings", i, "sphere"), f"sphere '{pairing.sphere}' is not in device.spheres"
        if procedure.extension is not None and procedure.extension not in self.extension_rods:
            yield (*loc, "extension"), f"extension rod '{procedure.extension}' is not in device.extension_rods"

    def check_effect(self, effect, loc):
        if isinstance(effect, PivotOffset) and effect.pivot not in self.pivots:
            yield (*loc, "pivot"), f"pivot '{effect.pivot}' is not in device.pivots"

    def parameter_location(self, name: str) -> list[str]:
        if name == "bar.length":
            return ["device", "length"]
        _, pivot, field = name.split(".")
        return ["device", "pivots", pivot, field]

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`\'s targets and sections (``dof`` joints, ``s`` times the PUMA 560\'s size): Goswami's fixture scaled to the robot: three spheres, three chucks;
        random points on his shells (Fig. 2; ``random_keyed_poses``): on their fixed axis the spheres' offset along it is nearly flat."""
        # Goswami's fixture: three spheres 60 mm off the flange axis, 80 mm out; three chucks on the table.
        spheres = [(60.0, 0.0), (-30.0, 51.962), (-30.0, -51.962)]
        targets = [f"sphere{i}: {{link: {dof}, x: {x:g}, y: {y:g}, z: 80}}" for i, (x, y) in enumerate(spheres, 1)]
        chucks = [(565.0, 0.0), (392.5, 100.0), (392.5, -100.0)]
        return targets, [
            "device:",
            "  type: ballbar",
            "  # Three magnetic chucks on a fixture in front of the robot, robot base frame (placeholders",
            "  # scaled from Goswami's PUMA fixture, specs/goswami_puma560.yaml).",
            "  pivots:",
            *(f"    chuck{i}: {{x: {mm(x * s)}, y: {mm(y * s)}, z: 0.0}}" for i, (x, y) in enumerate(chucks, 1)),
            "  spheres: [sphere1, sphere2, sphere3]",
            f"  length: {{value: {mm(460 * s)}, vary: false}}   # centre-to-centre at mid-travel",
            f"  travel: {mm(75 * s)}",
            "  noise: 0.084   # mm (Goswami's residual level)",
            "procedure:   # random points on Goswami's shells, every chuck with every sphere: a random bar length within the",
            "  # travel and the sphere's axis tilted at random (on the shells' fixed axis the spheres' offset along it is flat)",
            "  type: poses",
            "  count: 600   # drawn; those out of reach or of the bar's travel are dropped",
            "  seed: 1",
            "validation:   # another draw: held-out poses",
            "  type: poses",
            "  count: 300",
            "  seed: 2",
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        return (f"telescopic ball-bar, {length(self.length.value)} at mid-travel, travel {length(self.travel)}",
                [f"pivots {', '.join(self.pivots)}", f"spheres {', '.join(self.spheres)}"])

    def out_of_range(self, length) -> tuple[str, str, str]:
        return (f"outside the bar's travel (device.travel {length(self.travel)}: within {length(self.travel / 2)} of mid-travel)",
                "bar travel", TRAVEL_KEYS)


class BallBarModel(DeviceModel):
    type = "ballbar"
    section = BallBar
    key_columns = ("pivot", "sphere")
    optional_key_columns = ("extension",)
    keyed_poses = True

    def __init__(self, spec: BallBar):
        self.spec = spec
        entries = point_entries("pivot", declared_points(spec.pivots))
        entries.append(parameter_entry("bar.length", "length", spec.length.declared()))
        self.parameters = ParameterSet(tuple(entries))

    def parameter_group(self, name: str) -> tuple[str, str] | None:
        """A pivot's position."""
        return named_group(name, "pivot", "pivot {}'s position")

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return (Channel("length", "length"),)

    def target(self, key: Key) -> str | None:
        return key[1]

    def extension(self, key: Key) -> float:
        """Length of the extension rod of a key (0 without one)."""
        return self.spec.extension_rods[key[2]] if key[2] else 0.0

    def reach(self, key: Key) -> float:
        """Nominal centre-to-centre length at mid-travel, with the key's extension rod (the shells' radius)."""
        return self.spec.length.value + self.extension(key)

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        centre = ca.vertcat(*(sym[f"pivot.{key[0]}.{c}"] for c in "xyz"))
        return ca.norm_2(pose[:3, 3] - centre) + self.spec.length.value - sym["bar.length"]

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        return np.full(np.shape(np.atleast_2d(readings)), declared(self.spec.noise))

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        pairing = f"{key[0]}-{key[1]}" + (f"+{key[2]}" if key[2] else "")
        return {"target": key[1], "pairing": pairing}

    def measurable(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Within the LVDT travel: |length - mid-travel length| <= travel / 2."""
        readings = np.atleast_2d(readings)
        return np.abs(readings[:, 0] - self.reach(key)) <= self.spec.travel / 2

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        return {"length": "length"}, {}

    def key_names(self, robot) -> dict[str, set[str]]:
        return {"pivot": set(self.spec.pivots), "sphere": set(self.spec.spheres), "extension": set(self.spec.extension_rods) | {""}}

    def candidate_effects(self, free: set[str]) -> list[EffectSpec]:
        out = [] if "bar.length" in free else [EffectSpec(BALLBAR_LENGTH)]
        return out + [EffectSpec(PIVOT_OFFSET, part=p) for p in self.spec.pivots if not any(f"pivot.{p}.{c}" in free for c in "xyz")]

    def centre(self, key: Key, values: dict[str, float]) -> np.ndarray:
        return np.array([values[f"pivot.{key[0]}.{c}"] for c in "xyz"])

    def random_keyed_poses(self, spec, kinematics, count: int, rng: np.random.Generator) -> tuple[np.ndarray, list[Key], dict[str, int]]:
        """Random points on Goswami's hemispherical shells (Fig. 2) around each pivot of the spec's pairings, at a
        random latitude within the shells' range, a random longitude and a random bar length within the LVDT travel,
        the sphere's axis tilted at random about the shells' (halfway between down and the pivot); each solved by the
        nominal model's inverse kinematics (Stone 5.4, several starts) within the joint limits, where the arm holds
        a sphere's axis at fewer than half of them, the others at their points alone (procedures/shells.py)."""
        pairs, extension, (low, high) = _pairings(spec)
        values = self.parameters.values(self.parameters.nominal)
        pair = rng.integers(len(pairs), size=count)
        latitude, longitude = rng.uniform(low, high, count), rng.uniform(0.0, 2 * np.pi, count)
        spread = rng.uniform(-TRAVEL_USED / 2, TRAVEL_USED / 2, count) * self.spec.travel
        goals, keys = np.zeros((count, 6)), []
        for i in range(count):
            pivot, sphere = pairs[pair[i]]
            key = (pivot, sphere, extension)
            centre = self.centre(key, values)
            radius = self.reach(key) + spread[i]
            point = on_sphere(centre, radius, latitude[i], longitude[i])
            axis = (centre - point) / radius + [0.0, 0.0, -1.0] + TILT * rng.normal(size=3)
            goals[i] = [*point, *(axis / np.linalg.norm(axis))]
            keys.append(key)
        Q = np.full((count, kinematics.dof), np.nan)
        for sphere in dict.fromkeys(k[1] for k in keys):
            rows = np.flatnonzero([k[1] == sphere for k in keys])
            Q[rows] = ik.solve_pointing_where_held(kinematics, goals[rows, :3], goals[rows, 3:], sphere, int(rng.integers(2**31)))[0]
        return Q, keys, {}


def _pairings(spec) -> tuple[list[tuple[str, str]], str | None, tuple[float, float]]:
    """The pivot/sphere pairs, extension rod and latitude range (rad) of the spec's shells, else every pair."""
    shells = next((p for p in (spec.procedure, spec.validation) if getattr(p, "type", None) == "shells"), None)
    if shells is None:
        pairs = [(pivot, sphere) for pivot in spec.device.pivots for sphere in spec.device.spheres]
        return pairs, None, tuple(np.radians(DEFAULT_LATITUDES))
    pairs = [(p.pivot, p.sphere) for p in shells.pairings]
    return pairs, shells.extension, (min(shells.latitudes), max(shells.latitudes))

