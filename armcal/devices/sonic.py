"""Sonic digitizer: slant ranges from a sparker to each microphone, Stone 6.3.

Readings are either the slant ranges themselves (``s_A, s_B, ...``) or the
target's position triangulated by the instrument in the sensor frame
(``x, y, z``, (6.1)-(6.6), general non-right triangle). The sensor frame has its
origin at microphone C, y towards B and z out of the plane of A, B, C.

The speed of sound and Stone's compensation (App. E): the instrument converts a
time of flight t* to a range with its internal speed S*: s = S* t*. With the
speed varying linearly along the line of sight from v_T at the target to v_M at
the microphone (assumption B-3), dx/dt = v_T + mu x (E.2), so a true distance L
takes t* = ln(1 + mu L / v_T) / mu and, conversely, L = v_T (exp(mu t*) - 1) / mu
(E.3) with mu = (v_M - v_T) / L (E.4).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Annotated, Any, ClassVar, Literal, Union

import casadi as ca
import numpy as np
from pydantic import Field, ValidationInfo, WrapValidator

from armcal.devices.base import Channel, DeviceModel, Key, named_group, transform_point
from armcal.effects.effect_type import EffectType
from armcal.effects.library import EffectSpec
from armcal.effects.types.sensor_scale import SENSOR_SCALE
from armcal.support.errors import UserError
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, parameter_entry, point_entries, pose_entries
from armcal.kinematics.transforms import xyz_zyx
from armcal.spec_parts.base import Length, LengthParam, Number, Parameter, ScaleParam, SpecModel, declared_pose, declared_points, fixed
from armcal.spec_parts.starter import mm
from armcal.spec_parts.instrument import AUTO, ESTIMATE_HELP, GROUPS_HELP, DeviceSpec, Point, is_auto
from armcal.spec_parts.robot import Pose

PRIMARY = ("A", "B", "C")  # microphones used to triangulate (s_1, s_2, s_3 of 6.1-6.6)
ROOM_TEMPERATURE = 21.1  # degC, 70 F: the sonic digitizer's nominal conditions
HELD_OUT_SHIFT = 20.0  # deg: the starter's held-out sweeps start this far from the maker's home on every joint


class RangeBias(SpecModel):
    """A constant bias of one microphone's slant range (Stone's unidentified prototype limit)."""

    type: Literal["range_bias"]
    microphone: str = Field(description="microphone whose range is biased (from device.microphones)")
    bias: LengthParam = Parameter(value=0.0)


class RangeBiasType(EffectType):
    """range_bias: a constant added to one microphone's slant range s_<microphone>."""

    name = "range_bias"
    spec_model = RangeBias
    part_key = "microphone"

    def fields(self, effect):
        return [("bias", "length")]

    def reading(self, effect, channel, reading, value):
        return reading + value("bias") if channel.name == f"s_{effect.part}" else reading


RANGE_BIAS = RangeBiasType()


# The speed of sound (App. E)
ZERO_CELSIUS_SPEED = 331_450.0  # mm/s in dry air at 0 degC
ROD_NEAR = 300.0  # mm from a calibration rod's microphone to its near sparker


def speed_of_sound(temperature_c: np.ndarray | float) -> np.ndarray:
    """Speed of sound in air (mm/s) at a temperature in degC (ideal gas, ~0.6 m/s per degC)."""
    return ZERO_CELSIUS_SPEED * np.sqrt(1.0 + np.asarray(temperature_c, dtype=float) / 273.15)


def raw_range(distance: np.ndarray, v_target: np.ndarray, v_microphone: np.ndarray, internal_speed: float) -> np.ndarray:
    """What the instrument reads for a true distance: S* t*, with t* from integrating (E.2)."""
    distance, v_target, v_microphone = np.broadcast_arrays(distance, v_target, v_microphone)
    mu = (v_microphone - v_target) / distance
    with np.errstate(divide="ignore", invalid="ignore"):
        time = np.where(np.abs(mu) > 1e-12, np.log1p(mu * distance / v_target) / mu, distance / v_target)
    return internal_speed * time


def rod_ratio(near: np.ndarray, far: np.ndarray, rod_length: float) -> np.ndarray:
    """f = D / (s_far - s_near): true over internal speed of sound at a rod's microphone (E.1)."""
    return rod_length / (np.asarray(far) - np.asarray(near))


def true_range(raw: np.ndarray, f_target: np.ndarray, f_microphone: np.ndarray, iterations: int = 50) -> np.ndarray:
    """Solve (E.3)-(E.4) for L by Jacobi (fixed-point) iteration, speeds as ratios f = v / S*.

    With t* = s / S*, (E.3) reads L = f_T s (exp(mu' s) - 1) / (mu' s) with
    mu' = (f_M - f_T) / L; the iteration starts from L = f_T s.
    """
    raw, f_target, f_microphone = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (raw, f_target, f_microphone)))
    length = f_target * raw
    for _ in range(iterations):
        x = (f_microphone - f_target) / length * raw  # mu' s
        factor = np.where(np.abs(x) > 1e-12, np.expm1(x) / np.where(x == 0, 1.0, x), 1.0 + x / 2)
        updated = f_target * raw * factor
        if np.allclose(updated, length, rtol=0.0, atol=1e-9):
            return updated
        length = updated
    return length


def vertical(microphones: dict[str, np.ndarray]) -> np.ndarray:
    """Unit 'up' in the sensor frame: in the sensor plane, across A-C (which is level) towards B (6.3.1)."""
    a, b, c = (np.asarray(microphones[m], dtype=float) for m in ("A", "B", "C"))
    level = (a - c) / np.linalg.norm(a - c)
    up = (b - c) - np.dot(b - c, level) * level
    return up / np.linalg.norm(up)


def ratio_at(height: np.ndarray, heights: tuple[float, float], ratios: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Speed ratio linearly interpolated in height between two rods (B-3)."""
    (h1, h2), (f1, f2) = heights, ratios
    return f1 + (np.asarray(height) - h1) * (f2 - f1) / (h2 - h1)


def compensate(
    raw: dict[str, np.ndarray],
    rods: dict[str, np.ndarray],
    microphones: dict[str, np.ndarray],
) -> dict[str, np.ndarray]:
    """Stone's slant range compensation (App. E.2): raw ranges -> true ranges per microphone.

    ``raw``: readings per primary microphone (A, B, C); ``rods``: speed ratio f per
    rod microphone (E.1), one or two of them; ``microphones``: nominal positions.
    Overall correction by the mean ratio (E.5) gives a first triangulation whose
    height sets the ratio at the target; each range is then solved from (E.3).
    """
    up = vertical(microphones)
    names = list(rods)
    if len(names) == 1:
        names = names * 2
    heights = tuple(float(np.dot(microphones[m], up)) for m in names)
    ratios = tuple(rods[m] for m in names)
    if heights[0] == heights[1]:
        heights = (heights[0], heights[0] + 1.0)  # one level: a uniform ratio
    f_average = (ratios[0] + ratios[1]) / 2  # (E.5)
    w = microphone_distances(microphones)
    first = np.stack(triangulate(*(f_average * raw[m] for m in PRIMARY), *w), axis=-1)
    f_target = ratio_at(first @ up, heights, ratios)
    return {
        m: true_range(raw[m], f_target, ratio_at(float(np.dot(microphones[m], up)), heights, ratios)) for m in raw
    }


class RangeNoise(SpecModel):
    """Range noise sigma = a * range + b, Stone (7.9)."""

    a: Number = Field(ge=0.0, description="dimensionless slope of sigma with range")
    b: Length = Field(gt=0.0, description="sigma at zero range")


class CalibrationRod(SpecModel):
    """Two sparkers a known distance apart, level with a microphone, Stone App. E.1."""

    length: Length = Field(gt=0.0, description="distance between the rod's two sparkers")
    microphone: str = Field(description="microphone the rod is level with (B or D in Stone's array)")


def _range_noise_or_auto(value: Any, handler, info: ValidationInfo) -> "RangeNoise | str":
    if is_auto(value):
        return AUTO
    if not isinstance(value, (dict, RangeNoise)):
        raise ValueError(f"expected auto or {{a, b}} (sigma = a * range + b), got {value!r}")
    return RangeNoise.model_validate(value, context=info.context)


class SonicDigitizer(DeviceSpec):
    """Ultrasonic digitizer: slant ranges from a sparker to each microphone (Stone 6.3)."""

    type: Literal["sonic_digitizer"]
    microphones: dict[str, Point] = Field(min_length=3, max_length=4, description="microphone positions in the sensor frame (A, B, C[, D])")
    robot_base: Pose = Field(Pose(), description="robot base frame in the sensor frame (free unless fixed)")
    speed_of_sound: Length = Field(gt=0.0, description="nominal speed of sound, length per second")
    readings: Literal["ranges", "points"] = Field("ranges", description="what the fit takes: its slant ranges, or the points it triangulates from them")
    calibration_rods: list[CalibrationRod] = Field([], description="rods for the speed-of-sound compensation (App. E.1)")
    temperature_gradient: float = Field(0.0, description="vertical temperature gradient, degC per metre (App. E, B-3)")
    noise: Annotated[Union[RangeNoise, Literal["auto"]], WrapValidator(_range_noise_or_auto)] = Field(
        description="range noise sigma = a * range + b (7.9), or auto: one sigma per group, estimated from the data"
    )
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target", "microphone"]] = Field(["kind"], description=GROUPS_HELP)
    resolution: Length = Field(0.1, ge=0.0, description="range quantisation (0.01 cm for the GP-8-3D)")
    range_limits: tuple[Length, Length] = Field((300.0, 2500.0), description="shortest and longest range the digitizer reads")
    scale: ScaleParam = fixed(1.0)

    procedures: ClassVar[tuple[str, ...]] = ("circle_point",)
    instrument_effects: ClassVar[tuple[EffectType, ...]] = (SENSOR_SCALE, RANGE_BIAS)
    fixes_positions: ClassVar[bool] = True

    def check(self, spec):
        for i, rod in enumerate(self.calibration_rods):
            if rod.microphone not in self.microphones:
                yield ("device", "calibration_rods", i, "microphone"), f"microphone '{rod.microphone}' is not in device.microphones"

    def check_effect(self, effect, loc):
        if isinstance(effect, RangeBias) and effect.microphone not in self.microphones:
            yield (*loc, "microphone"), f"microphone '{effect.microphone}' is not in device.microphones"

    def parameter_location(self, name: str) -> list[str]:
        if name == "sonic.scale":
            return ["device", "scale"]
        if name.startswith("mic."):
            _, microphone, field = name.split(".")
            return ["device", "microphones", microphone, field]
        return super().parameter_location(name)

    @staticmethod
    def starter(dof: int, home: list[float], s: float) -> tuple[list[str], list[str]]:
        """`armcal new`\'s targets and sections (``dof`` joints, ``s`` times the PUMA 560\'s size): Stone's GP-8-3D array scaled to the robot; circle-point sweeps from the maker's home, held-out sweeps from another signature."""
        held_out = ", ".join(f"{v - HELD_OUT_SHIFT if v > 0 else v + HELD_OUT_SHIFT:g}" for v in home)
        home = ", ".join(f"{v:g}" for v in home)
        targets = f"  targets: [{', '.join(f'sparker{i}' for i in range(1, dof + 1))}]"

        def fixed_point(x: float, y: float) -> str:
            return f"{{x: {{value: {mm(x)}, vary: false}}, y: {{value: {mm(y)}, vary: false}}, z: {{value: 0, vary: false}}}}"

        side = 1430.0 * s
        return [f"sparker{i}: {{link: {i}, x: {mm(300 * s)}, y: {mm(150 * s)}, z: {mm(100 * s)}}}   # on link {i}, its DH frame" for i in range(1, dof + 1)], [
            "device:",
            "  type: sonic_digitizer",
            "  # Stone's GP-8-3D array (specs/puma560_dh.yaml) scaled to the robot: origin at microphone C,",
            "  # y towards B, z out of the sensor plane; D only for the speed-of-sound rods.",
            "  microphones:",
            f"    A: {fixed_point(side, 1440.87 * s)}",
            f"    B: {fixed_point(0, side)}",
            f"    C: {fixed_point(0, 0)}",
            f"    D: {fixed_point(side, 0)}",
            f"  robot_base: {{x: {mm(1597.32 * s)}, y: {mm(155.41 * s)}, z: {mm(694.22 * s)}, rz: -135.0, ry: 25.0, rx: 90.0}}",
            "  speed_of_sound: 344000   # mm/s at 21 degC",
            "  calibration_rods:",
            "    - {length: 1000.0, microphone: B}",
            "    - {length: 1000.0, microphone: D}",
            "  noise: {a: 9.6432e-5, b: 0.03}   # sigma = a * range + b, mm (Stone 7.9)",
            "  resolution: 0.1",
            f"  range_limits: [300, {mm(max(2500.0, 2500.0 * s))}]",
            "procedure:   # circle-point sweeps (Stone 4.5, 6.4): each joint alone, from the maker's home",
            "  type: circle_point",
            f"  signature: [{home}]",
            targets,
            "  points_per_joint: 20",
            "  averaging: 10",
            f"validation:   # held-out sweeps from another signature: the home, each joint {HELD_OUT_SHIFT:g} deg towards zero (past it from zero)",
            "  type: circle_point",
            f"  signature: [{held_out}]",
            targets,
            "  points_per_joint: 20",
            "  averaging: 10",
        ]

    def describe(self, length) -> tuple[str, list[str]]:
        return "sonic digitizer (slant ranges)", [f"microphones {', '.join(self.microphones)}", f"{len(self.calibration_rods)} calibration rods"]


def triangulate(s1, s2, s3, w_ab, w_bc, w_ac):
    """Target (x, y, z) in the sensor frame from slant ranges to A, B, C, Stone (6.1)-(6.6).

    Works on numpy arrays and CasADi symbols alike. cos(theta) (6.5) is the angle
    at C between CA and CB; r (6.4) the projection of the target on CA.
    """
    sqrt = ca.sqrt if isinstance(s1, (ca.SX, ca.MX)) else np.sqrt
    cos_t = (w_ac**2 + w_bc**2 - w_ab**2) / (2 * w_ac * w_bc)  # (6.5)
    sin_t = sqrt(1 - cos_t**2)  # (6.6), as tan(theta) = sin/cos
    r = (w_ac**2 + s3**2 - s1**2) / (2 * w_ac)  # (6.4)
    y = (w_bc**2 + s3**2 - s2**2) / (2 * w_bc)  # (6.2)
    x = (r - y * cos_t) / sin_t  # (6.1), rearranged
    z_squared = s3**2 - x**2 - y**2  # (6.3)
    z = sqrt(ca.fmax(z_squared, 0) if isinstance(s1, (ca.SX, ca.MX)) else np.maximum(z_squared, 0))
    return x, y, z


def microphone_distances(microphones: dict[str, np.ndarray]) -> tuple[float, float, float]:
    """w_AB, w_BC, w_AC from microphone positions."""
    a, b, c = (np.asarray(microphones[m], dtype=float) for m in PRIMARY)
    return float(np.linalg.norm(a - b)), float(np.linalg.norm(b - c)), float(np.linalg.norm(a - c))


class SonicModel(DeviceModel):
    """Slant ranges scale * |P x - mic| (P = robot base in the sensor frame, 4.48), or their triangulation."""

    type = "sonic_digitizer"
    section = SonicDigitizer

    @classmethod
    def from_spec(cls, spec, mode: str | None) -> "SonicModel":
        averaging = spec.procedure.averaging if spec.procedure is not None and spec.procedure.type == "circle_point" else 1
        return cls(spec.device, averaging=averaging, mode=mode or spec.device.readings)

    @staticmethod
    def readings_mode(header: list[str], requested: str | None) -> str | None:
        """Triangulated points when that is all the file holds, else as asked (None: as the spec's section says)."""
        return "points" if "x" in header and not any(h.startswith("s_") for h in header) else requested

    def __init__(self, spec: SonicDigitizer, averaging: int = 1, mode: str = "ranges"):
        if mode not in ("ranges", "points"):
            raise ValueError(f"mode must be 'ranges' or 'points', not {mode!r}")
        self.spec = spec
        self.mode = mode
        self.averaging = averaging
        self.microphones = tuple(spec.microphones)
        entries = pose_entries("robot_base", declared_pose(spec.robot_base)) + point_entries("mic", declared_points(spec.microphones))
        entries.append(parameter_entry("sonic.scale", "scale", spec.scale.declared()))
        self.parameters = ParameterSet(tuple(entries))
        nominal = dict(zip(self.parameters.names, self.parameters.nominal))
        self.nominal_microphones = {m: np.array([nominal[f"mic.{m}.{c}"] for c in "xyz"]) for m in self.microphones}

    def parameter_group(self, name: str) -> tuple[str, str] | None:
        """A microphone's position, or the placement robot_base."""
        return named_group(name, "mic", "microphone {}'s position") or super().parameter_group(name)

    def channels(self, key: Key) -> tuple[Channel, ...]:
        if self.mode == "points":
            return tuple(Channel(c, "length") for c in "xyz")
        return tuple(Channel(f"s_{m}", "length") for m in self.microphones)

    def target(self, key: Key) -> str | None:
        return key[0]

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        point = transform_point(pose_from_symbols(sym, "robot_base"), pose[:3, 3])
        ranges = {
            m: sym["sonic.scale"] * ca.norm_2(point - ca.vertcat(*(sym[f"mic.{m}.{c}"] for c in "xyz")))
            for m in self.microphones
        }
        if self.mode == "ranges":
            return ca.vertcat(*ranges.values())
        w = microphone_distances(self.nominal_microphones)  # the instrument triangulates with its nominal geometry
        return ca.vertcat(*triangulate(*(ranges[m] for m in PRIMARY), *w))

    def range_sigma(self, ranges: np.ndarray) -> np.ndarray:
        """sigma = a * range + b (7.9), reduced by averaging N_avg readings.

        With calibration rods, a compensated range L = f s also carries the rod
        ratio's noise (E.1): sigma_f / f = sqrt(sigma(s_near)^2 + sigma(s_far)^2) / D.
        With ``noise: auto``, 1 mm: each group's sigma is estimated from the data.
        """
        noise = self.spec.noise
        if noise == AUTO:
            return np.ones(np.shape(ranges))
        sigma = (noise.a * ranges + noise.b) / np.sqrt(self.averaging)
        if self.spec.calibration_rods:
            rod = self.spec.calibration_rods[0].length
            near, far = (noise.a * d + noise.b for d in (ROD_NEAR, ROD_NEAR + rod))
            relative = np.hypot(near, far) / np.sqrt(self.averaging) / rod
            sigma = np.hypot(sigma, relative * ranges)
        return sigma

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        readings = np.atleast_2d(readings)
        if self.mode == "ranges":
            return self.range_sigma(readings)
        return self._point_sigma(readings)

    def noise_kind(self, field: str) -> str:
        return "range" if self.mode == "ranges" else "point"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        keys = {"target": key[0]}
        if self.mode == "ranges":
            keys["microphone"] = channel.removeprefix("s_")
        elif "microphone" in self.spec.noise_groups:
            raise UserError("noise_groups: microphone needs the slant ranges; these data hold triangulated points")
        return keys

    def _point_sigma(self, points: np.ndarray) -> np.ndarray:
        """Per-coordinate sigma of triangulated points, propagating the range noise (correlations dropped)."""
        w = microphone_distances(self.nominal_microphones)
        s = ca.SX.sym("s", 3)
        jacobian = ca.Function("J", [s], [ca.jacobian(ca.vertcat(*triangulate(s[0], s[1], s[2], *w)), s)])
        mics = np.array([self.nominal_microphones[m] for m in PRIMARY])
        ranges = np.linalg.norm(points[:, None, :] - mics[None, :, :], axis=2)  # (N, 3)
        sigma_s = self.range_sigma(ranges)
        J = np.array(jacobian.map(len(points))(ranges.T)).T.reshape(len(points), 3, 3).transpose(0, 2, 1)
        return np.sqrt(np.einsum("nij,nj->ni", J**2, sigma_s**2))

    def prepare(self, measurements):
        """Raw slant ranges -> compensated ranges (App. E, when rod ranges were recorded) -> points if fitted so."""
        readings = dict(measurements.readings)
        ranges = {m: readings[f"s_{m}"] for m in self.microphones if f"s_{m}" in readings}
        if not ranges:
            return measurements  # the file holds triangulated points already
        rods = {
            rod.microphone: rod_ratio(measurements.extras[f"rod_{rod.microphone}_1"], measurements.extras[f"rod_{rod.microphone}_2"], rod.length)
            for rod in self.spec.calibration_rods
            if f"rod_{rod.microphone}_1" in measurements.extras
        }
        if rods:
            ranges = compensate(ranges, rods, self.nominal_microphones)
        if self.mode == "points":
            w = microphone_distances(self.nominal_microphones)
            readings = dict(zip("xyz", triangulate(*(ranges[m] for m in PRIMARY), *w)))
        else:
            readings.update({f"s_{m}": value for m, value in ranges.items()})
            for m in self.microphones:  # a microphone without a column (s_D is optional): no readings
                readings.setdefault(f"s_{m}", np.full(len(measurements.q), np.nan))
        return replace(measurements, readings=readings)

    def measurable(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Ranges within the instrument's range limits (ranges mode; points are always readable)."""
        if self.mode != "ranges":
            return np.ones(len(readings), dtype=bool)
        low, high = self.spec.range_limits
        return np.all(((readings >= low) & (readings <= high)) | np.isnan(readings), axis=1)

    def visible(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """In front of the microphone plane (z > 0 in the sensor frame) and within the range limits."""
        ranges_model = SonicModel(self.spec, self.averaging, mode="ranges") if self.mode != "ranges" else self
        points = ranges_model._sensor_points(poses, pd)
        return (points[:, 2] > 0) & ranges_model.measurable(key, ranges_model.evaluate(key, poses, pd))

    def _sensor_points(self, poses: np.ndarray, pd: np.ndarray | None) -> np.ndarray:
        values = self.parameters.values(self.parameters.nominal if pd is None else pd)
        base = xyz_zyx(*(values[f"robot_base.{f}"] for f in ("x", "y", "z", "rz", "ry", "rx")))
        return np.einsum("ij,nj->ni", base[:3, :3], np.asarray(poses)[:, :3, 3]) + base[:3, 3]

    def reading_columns(self, header: list[str]) -> tuple[dict[str, str], dict[str, str]]:
        """Slant ranges s_A, s_B, s_C (s_D optional) and calibration-rod ranges, or triangulated x, y, z."""
        if self.readings_mode(header, "ranges") == "points":
            return {c: "length" for c in "xyz"}, {}
        ranges = {f"s_{m}": "length" for m in self.microphones if m in PRIMARY}
        extra = {f"s_{m}": "length" for m in self.microphones if m not in PRIMARY}
        rods = {f"rod_{rod.microphone}_{i}": "length" for rod in self.spec.calibration_rods for i in (1, 2)}
        return ranges, {**extra, **rods}

    def target_aliases(self, robot) -> dict[str, str]:
        """A sparker named by the link that carries it (the contract's target 1..N), where it is the link's only one."""
        on_link: dict[int, list[str]] = {}
        for name, target in robot.targets.items():
            on_link.setdefault(target.link, []).append(name)
        return {str(link): names[0] for link, names in on_link.items() if len(names) == 1 and link >= 1}

    def candidate_effects(self, free: set[str]) -> list[EffectSpec]:
        out = [] if "sonic.scale" in free else [EffectSpec(SENSOR_SCALE)]
        return out + ([EffectSpec(RANGE_BIAS, part=m) for m in self.microphones] if self.mode == "ranges" else [])

    def simulated_readings(self, key: Key, values: np.ndarray, poses: np.ndarray, pd: np.ndarray, settings, rng) -> tuple:
        """Raw slant ranges through a vertically stratified air (B-3), N_avg noisy quantised readings averaged; the
        calibration rods' ranges (App. E.1) recorded beside them."""
        air = settings.temperature[0] if settings.temperature else ROOM_TEMPERATURE
        up = vertical(self.nominal_microphones)
        temperature = lambda height: air + self.spec.temperature_gradient * height / 1000.0  # noqa: E731
        target_speed = speed_of_sound(temperature(self._sensor_points(poses, pd) @ up))
        raw = np.empty_like(values)
        for c, microphone in enumerate(self.microphones):
            microphone_speed = speed_of_sound(temperature(self.nominal_microphones[microphone] @ up))
            raw[:, c] = raw_range(values[:, c], target_speed, microphone_speed, self.spec.speed_of_sound)
        rods = {}
        for rod in self.spec.calibration_rods:
            speed = speed_of_sound(temperature(self.nominal_microphones[rod.microphone] @ up))
            for i, distance in enumerate((ROD_NEAR, ROD_NEAR + rod.length), start=1):
                rods[f"rod_{rod.microphone}_{i}"] = np.full(len(raw), raw_range(distance, speed, speed, self.spec.speed_of_sound))
        averaged = lambda v: self._averaged_readings(v, rng, settings.noise_factor) if settings.noise else v  # noqa: E731
        return averaged(raw), np.ones(len(raw), dtype=bool), {name: averaged(column[:, None])[:, 0] for name, column in rods.items()}

    def _averaged_readings(self, values: np.ndarray, rng: np.random.Generator, factor: float) -> np.ndarray:
        """Mean of N_avg readings, each with noise k sigma(range) (7.9, 7.4.3) and quantised to the resolution."""
        sigma = factor * (self.spec.noise.a * values + self.spec.noise.b)
        readings = values[..., None] + rng.normal(size=(*values.shape, self.averaging)) * sigma[..., None]
        if self.spec.resolution > 0:
            readings = np.round(readings / self.spec.resolution) * self.spec.resolution
        return readings.mean(axis=-1)
