"""The ``device`` section: the measuring instrument, discriminated on ``type``.

Positions and poses of the instrument are device parameters (free or fixed like
robot parameters). ``robot_base`` is the pose of the robot base frame in the
instrument frame (Stone's P, (4.48); F.3 for his sensor).

A noise sigma is a value or ``auto``: estimated from the data by variance
component estimation (identify/variance.py), per group of readings
(``noise_groups``); ``estimate_noise: true`` estimates the declared ones too and
tests each estimate against its declared value.
"""

from __future__ import annotations

from datetime import date
from typing import Annotated, Any, Literal, Union

from pydantic import Field, ValidationInfo, WithJsonSchema, WrapValidator, field_validator

from armcal.spec.base import Length, LengthParam, Number, ScaleParam, SpecModel, convert, fixed, quantity_schema
from armcal.spec.robot import Pose

AUTO = "auto"  # a noise sigma estimated from the data


def _is_auto(value: Any) -> bool:
    return isinstance(value, str) and value.strip() == AUTO


def _sigma_or_auto(kind: str):
    """A positive quantity of ``kind``, or ``auto``."""

    def validate(value: Any, handler, info: ValidationInfo) -> float | str:
        if _is_auto(value):
            return AUTO
        try:
            sigma = convert(value, info, kind)
        except ValueError as exc:
            raise ValueError(f"{exc} (or write auto, to estimate it from the data)") from None
        if not sigma > 0:
            raise ValueError(f"a noise sigma must be above 0 (or auto, to estimate it from the data), got {value!r}")
        return sigma

    schema = {"anyOf": [quantity_schema(kind), {"const": AUTO}], "description": f"{kind} sigma, or auto (estimated from the data)"}
    return Annotated[Union[float, Literal["auto"]], WrapValidator(validate), WithJsonSchema(schema)]


LengthSigma = _sigma_or_auto("length")
AngleSigma = _sigma_or_auto("angle")
GROUPS_HELP = (
    "how readings are grouped when their noise is estimated: always by kind (the noise field: positions, "
    "orientations, angles, lengths, ranges), and by each further key listed"
)
ESTIMATE_HELP = "estimate the declared noise sigmas from the data too, use the estimates, and test each against its declared value"


class Instrument(SpecModel):
    """The instrument's identity and its own calibration, for traceability (ISO/IEC 17025 7.8.4); printed as given."""

    maker: str | None = Field(None, description="manufacturer")
    model: str | None = Field(None, description="model name")
    serial: str | None = Field(None, description="the instrument's serial number")
    calibrated: date | None = Field(None, description="date of the instrument's last calibration (YYYY-MM-DD)")
    certificate: str | None = Field(None, description="number of the instrument's calibration certificate")
    mpe: str | None = Field(None, description='maximum permissible error as its maker states it, with its unit, e.g. "±(15 µm + 6 µm/m)"')


class NoiseEstimation(SpecModel):
    """What every device shares: its identity (``instrument``), which noise sigmas are estimated from the data, and by
    which groups (each device declares ``noise``, ``noise_groups`` and ``estimate_noise``)."""

    instrument: Instrument | None = Field(None, description="the instrument's identity and calibration, printed on the certificate")

    def noise_fields(self) -> tuple[str, ...]:
        """The spec fields that hold this device's noise sigmas."""
        return ("noise",)

    def estimated_fields(self) -> tuple[str, ...]:
        """The noise fields estimated from the data: those set to auto, all with estimate_noise."""
        return tuple(f for f in self.noise_fields() if self.estimate_noise or getattr(self, f) == AUTO)

    @field_validator("noise_groups", check_fields=False)
    @classmethod
    def _groups_need_estimation(cls, groups: list[str], info: ValidationInfo) -> list[str]:
        """Given at all, noise_groups must group something that is estimated (fields before it are validated)."""
        if len(set(groups)) != len(groups):
            raise ValueError("noise_groups lists a group twice")
        given = info.data
        if not given.get("estimate_noise") and AUTO not in (given.get("noise"), given.get("orientation_noise")):
            raise ValueError("noise_groups only matters when a noise is auto or estimate_noise is true")
        return groups


class Point(SpecModel):
    """A fixed point of the instrument (microphone, pivot)."""

    x: LengthParam
    y: LengthParam
    z: LengthParam


class RangeNoise(SpecModel):
    """Range noise sigma = a * range + b, Stone (7.9)."""

    a: Number = Field(ge=0.0, description="dimensionless slope of sigma with range")
    b: Length = Field(gt=0.0, description="sigma at zero range")


class CalibrationRod(SpecModel):
    """Two sparkers a known distance apart, level with a microphone, Stone App. E.1."""

    length: Length = Field(gt=0.0, description="distance between the rod's two sparkers")
    microphone: str = Field(description="microphone the rod is level with (B or D in Stone's array)")


def _range_noise_or_auto(value: Any, handler, info: ValidationInfo) -> "RangeNoise | str":
    if _is_auto(value):
        return AUTO
    if not isinstance(value, (dict, RangeNoise)):
        raise ValueError(f"expected auto or {{a, b}} (sigma = a * range + b), got {value!r}")
    return RangeNoise.model_validate(value, context=info.context)


class SonicDigitizer(NoiseEstimation):
    """Ultrasonic digitizer: slant ranges from a sparker to each microphone (Stone 6.3)."""

    type: Literal["sonic_digitizer"]
    microphones: dict[str, Point] = Field(min_length=3, max_length=4, description="microphone positions in the sensor frame (A, B, C[, D])")
    robot_base: Pose = Field(Pose(), description="robot base frame in the sensor frame (free unless fixed)")
    speed_of_sound: Length = Field(gt=0.0, description="nominal speed of sound, length per second")
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


class BallBar(NoiseEstimation):
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


class Station(SpecModel):
    """A theodolite station: its pose in the instrument (world) frame."""

    pose: Pose = Field(description="station pose in the instrument (world) frame")


class ScaleBar(SpecModel):
    """A bar of calibrated length whose two end marks are sighted too; it fixes the network's scale."""

    length: Length = Field(gt=0.0, description="calibrated distance between the bar's marks")
    noise: Length = Field(0.01, gt=0.0, description="uncertainty of the calibrated length")
    end1: Point = Field(description="approximate position of the first mark, instrument frame")
    end2: Point = Field(description="approximate position of the second mark, instrument frame")


class Theodolite(NoiseEstimation):
    """Theodolite network: azimuth and elevation of targets seen from each station."""

    type: Literal["theodolite"]
    stations: dict[str, Station] = Field(min_length=1, description="theodolite stations by name")
    targets: list[str] = Field(min_length=1, description="names of robot targets sighted")
    robot_base: Pose = Pose()
    noise: AngleSigma = Field(description="angle noise sigma (arc-seconds typically), or auto (estimated from the data)")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target", "station"]] = Field(["kind"], description=GROUPS_HELP)
    scale_bar: ScaleBar | None = Field(None, description="a bar of calibrated length; without it the network's scale is not identifiable")


class Tracker(NoiseEstimation):
    """Laser tracker / CMM: 3D point (and optionally orientation) of a target."""

    type: Literal["tracker"]
    targets: list[str] = Field(min_length=1, description="names of robot targets measured")
    robot_base: Pose = Pose()
    noise: LengthSigma = Field(description="position noise sigma per coordinate, or auto (estimated from the data)")
    orientation: bool = Field(False, description="the data also hold the target's orientation rx, ry, rz")
    orientation_noise: AngleSigma | None = Field(None, description="orientation noise sigma (needed with orientation), or auto")
    estimate_noise: bool = Field(False, description=ESTIMATE_HELP)
    noise_groups: list[Literal["kind", "target"]] = Field(["kind"], description=GROUPS_HELP)
    scale: ScaleParam = fixed(1.0)

    def noise_fields(self) -> tuple[str, ...]:
        return ("noise", "orientation_noise") if self.orientation else ("noise",)


Device = Annotated[Union[SonicDigitizer, BallBar, Theodolite, Tracker], Field(discriminator="type")]
