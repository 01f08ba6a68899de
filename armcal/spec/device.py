"""The ``device`` section: the measuring instrument, discriminated on ``type``.

Positions and poses of the instrument are device parameters (free or fixed like
robot parameters). ``robot_base`` is the pose of the robot base frame in the
instrument frame (Stone's P, (4.48); F.3 for his sensor).
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from armcal.spec.base import Angle, Length, LengthParam, Number, ScaleParam, SpecModel, fixed
from armcal.spec.robot import Pose


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


class SonicDigitizer(SpecModel):
    """Ultrasonic digitizer: slant ranges from a sparker to each microphone (Stone 6.3)."""

    type: Literal["sonic_digitizer"]
    microphones: dict[str, Point] = Field(min_length=3, max_length=4, description="microphone positions in the sensor frame (A, B, C[, D])")
    robot_base: Pose = Field(Pose(), description="robot base frame in the sensor frame (free unless fixed)")
    speed_of_sound: Length = Field(gt=0.0, description="nominal speed of sound, length per second")
    calibration_rods: list[CalibrationRod] = Field([], description="rods for the speed-of-sound compensation (App. E.1)")
    temperature_gradient: float = Field(0.0, description="vertical temperature gradient, degC per metre (App. E, B-3)")
    noise: RangeNoise
    resolution: Length = Field(0.1, ge=0.0, description="range quantisation (0.01 cm for the GP-8-3D)")
    range_limits: tuple[Length, Length] = Field((300.0, 2500.0), description="shortest and longest range the digitizer reads")
    scale: ScaleParam = fixed(1.0)


class BallBar(SpecModel):
    """Telescopic ball-bar between a fixed pivot and a sphere on the robot (Goswami)."""

    type: Literal["ballbar"]
    pivots: dict[str, Point] = Field(min_length=1, description="magnetic chucks of the base fixture (world frame)")
    spheres: list[str] = Field(min_length=1, description="names of robot targets that carry a sphere")
    length: LengthParam = Field(description="centre-to-centre length at mid-travel, without extension rods")
    extension_rods: dict[str, Length] = Field({}, description="extension rods by name and length (Goswami's 46/61 cm bars)")
    travel: Length = Field(gt=0.0, description="LVDT travel (7.5 cm in Goswami)")
    noise: Length = Field(gt=0.0, description="length noise sigma")


class Station(SpecModel):
    """A theodolite station: its pose in the instrument (world) frame."""

    pose: Pose = Field(description="station pose in the instrument (world) frame")


class ScaleBar(SpecModel):
    """A bar of calibrated length whose two end marks are sighted too; it fixes the network's scale."""

    length: Length = Field(gt=0.0, description="calibrated distance between the bar's marks")
    noise: Length = Field(0.01, gt=0.0, description="uncertainty of the calibrated length")
    end1: Point = Field(description="approximate position of the first mark, instrument frame")
    end2: Point = Field(description="approximate position of the second mark, instrument frame")


class Theodolite(SpecModel):
    """Theodolite network: azimuth and elevation of targets seen from each station."""

    type: Literal["theodolite"]
    stations: dict[str, Station] = Field(min_length=1, description="theodolite stations by name")
    targets: list[str] = Field(min_length=1, description="names of robot targets sighted")
    robot_base: Pose = Pose()
    noise: Angle = Field(gt=0.0, description="angle noise sigma (arc-seconds typically)")
    scale_bar: ScaleBar | None = Field(None, description="a bar of calibrated length; without it the network's scale is not identifiable")


class Tracker(SpecModel):
    """Laser tracker / CMM: 3D point (and optionally orientation) of a target."""

    type: Literal["tracker"]
    targets: list[str] = Field(min_length=1, description="names of robot targets measured")
    robot_base: Pose = Pose()
    noise: Length = Field(gt=0.0, description="position noise sigma per coordinate")
    orientation: bool = Field(False, description="the data also hold the target's orientation rx, ry, rz")
    orientation_noise: Angle | None = Field(None, gt=0.0, description="orientation noise sigma (needed with orientation)")
    scale: ScaleParam = fixed(1.0)


Device = Annotated[Union[SonicDigitizer, BallBar, Theodolite, Tracker], Field(discriminator="type")]
