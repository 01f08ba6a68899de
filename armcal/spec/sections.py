"""Smaller spec sections: data files, simulation, declared effects, diagnosis, report."""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

from pydantic import Field

from armcal.spec.base import Angle, AngleParam, Length, LengthParam, Number, Parameter, ScaleParam, SpecModel
from armcal.spec.robot import Offset

DEG = math.pi / 180.0

EFFECT_TYPES = (
    "encoder_scale",
    "gear_harmonic",
    "joint_compliance",
    "backlash",
    "thermal_drift",
    "sensor_scale",
    "range_bias",
    "ballbar_length",
    "pivot_offset",
)


class Data(SpecModel):
    """Measured data files (CSV, contract columns), relative to the spec file."""

    calibration: str = Field(description="CSV file of the calibration measurements")
    validation: str | None = Field(None, description="CSV file of held-out measurements")
    instrument_moved: bool = Field(
        False, description="the tracker was set up anew for the validation data: re-register it there (robot kept)"
    )


class JointEffect(SpecModel):
    """An effect acting on one joint (1-based)."""

    joint: int = Field(ge=1, description="joint number, 1-based")


class EncoderScale(JointEffect):
    """theta = q (1 + scale): a joint's encoder gain error."""

    type: Literal["encoder_scale"]
    scale: ScaleParam = Parameter(value=0.0)


class GearHarmonic(JointEffect):
    """Sinusoidal transmission error of one order (Whitney & Lozinski): sin and cos amplitudes."""

    type: Literal["gear_harmonic"]
    order: int = Field(ge=1, description="harmonic order: cycles per joint (or motor) revolution")
    ratio: float = Field(1.0, gt=0.0, description="gear ratio for motor-side harmonics (1 = joint side)")
    sin: AngleParam = Parameter(value=0.0)
    cos: AngleParam = Parameter(value=0.0)


class LinkMass(SpecModel):
    """A lumped mass on a link for gravity torques: kg and centre of mass in the link frame."""

    link: int = Field(ge=1, description="link carrying the mass")
    mass: float = Field(gt=0.0, description="kg")
    x: Length = Field(0.0, description="centre of mass, link frame")
    y: Length = Field(0.0, description="centre of mass, link frame")
    z: Length = Field(0.0, description="centre of mass, link frame")


class JointCompliance(JointEffect):
    """Joint deflection = compliance x gravity torque from a lumped mass model."""

    type: Literal["joint_compliance"]
    compliance: Number = Field(0.0, description="rad per N m")
    vary: bool = Field(True, description="identify the compliance (else keep the value given)")
    masses: list[LinkMass] = Field([], description="lumped masses for the gravity torque (default: 5 kg at each link frame's origin beyond the joint)")


class Backlash(JointEffect):
    """Joint error = half_width x approach direction (needs dir columns)."""

    type: Literal["backlash"]
    half_width: AngleParam = Parameter(value=0.0)


class ThermalDrift(SpecModel):
    """Link lengths scaled by coefficient x (temperature - reference), or by drift rate x time."""

    type: Literal["thermal_drift"]
    source: Literal["temperature", "time"] = Field("temperature", description="the temperature column, or the time column t")
    coefficient: Number = Field(0.0, description="1/degC for temperature, 1/s for time")
    vary: bool = Field(True, description="identify the coefficient (else keep the value given)")
    reference_temperature: float = Field(20.0, description="degC")


class SensorScale(SpecModel):
    """Instrument scale error (speed of sound for the sonic digitizer)."""

    type: Literal["sensor_scale"]
    scale: ScaleParam = Parameter(value=0.0)


class RangeBias(SpecModel):
    """A constant bias of one microphone's slant range (Stone's unidentified prototype limit)."""

    type: Literal["range_bias"]
    microphone: str = Field(description="microphone whose range is biased (from device.microphones)")
    bias: LengthParam = Parameter(value=0.0)


class BallbarLength(SpecModel):
    """An offset of the ball-bar's length."""

    type: Literal["ballbar_length"]
    offset: LengthParam = Parameter(value=0.0)


class PivotOffset(Offset):
    """A displacement of one ball-bar pivot."""

    type: Literal["pivot_offset"]
    x: LengthParam = Parameter(value=0.0)
    y: LengthParam = Parameter(value=0.0)
    z: LengthParam = Parameter(value=0.0)
    pivot: str = Field(description="the pivot that moved (from device.pivots)")


Effect = Annotated[
    Union[
        EncoderScale,
        GearHarmonic,
        JointCompliance,
        Backlash,
        ThermalDrift,
        SensorScale,
        RangeBias,
        BallbarLength,
        PivotOffset,
    ],
    Field(discriminator="type"),
]


class Simulate(SpecModel):
    """How ``armcal simulate`` builds the true robot and its measurements.

    The true robot is the nominal chain with six small error freedoms after the
    base and after every link, and an encoder error per joint (Stone 7.1-7.8
    generalised): a richer model than any convention that is fitted.
    """

    seed: int = Field(0, ge=0, description="seed of the true robot and the noise")
    sigma_p: Length = Field(0.1, ge=0.0, description="positional manufacturing error sigma (Stone 7.2)")
    sigma_o: Angle = Field(0.01 * DEG, ge=0.0, description="orientational manufacturing error sigma (Stone 7.2)")
    sigma_e: Angle = Field(0.1 * DEG, ge=0.0, description="encoder calibration error sigma (Stone 7.2)")
    noise: bool = Field(True, description="add the instrument's noise to the readings")
    noise_factor: Number = Field(1.0, gt=0.0, description="k: the instrument's noise sigma times k (Stone 7.4.3)")
    effects: list[Effect] = Field([], description="hidden effects, never visible to the fit")
    time_step: float = Field(10.0, ge=0.0, description="seconds between samples (t column)")
    temperature: tuple[float, float] | None = Field(None, description="start and end temperature, degC")


class Fit(SpecModel):
    """How the parameters are identified."""

    method: Literal["least_squares", "s_model_features"] = Field(
        "least_squares", description="Levenberg-Marquardt on all data, or Stone's feature-based S-Model identification"
    )
    loss: Literal["linear", "huber", "cauchy"] = Field("linear", description="least squares, or a robust loss against gross errors")
    loss_scale: float = Field(3.0, gt=0.0, description="robust loss threshold, in noise sigmas")
    max_iterations: int = Field(100, ge=1, description="Levenberg-Marquardt iteration limit")
    sonic_readings: Literal["ranges", "points"] = Field(
        "ranges", description="fit the sonic digitizer's slant ranges or its triangulated points"
    )


class Diagnose(SpecModel):
    """The residual diagnosis loop after each fit."""

    enabled: bool = Field(True, description="run the diagnosis after the fit")
    alpha: float = Field(0.01, gt=0.0, lt=1.0, description="family-wise false-positive rate")
    max_rounds: int = Field(3, ge=0, description="effects added at most (one per round)")
    candidates: list[Literal[EFFECT_TYPES]] | None = Field(None, description="effect types tried (default: all the data allow)")  # type: ignore[valid-type]
    harmonic_orders: int = Field(3, ge=1, description="gear harmonics tried up to this order")
    holdout: Literal["validation", "kfold"] = Field(
        "validation",
        description="data that must confirm an effect: the validation set (its figures are then not independent of the choice), "
        "or k-fold cross-validation over the calibration poses (the validation set stays untouched for the final figures); "
        "without validation data, k-fold",
    )
    folds: int = Field(5, ge=2, description="k of the k-fold cross-validation")


class IsoCube(SpecModel):
    """Where the ISO 9283 test cube stands: its centre in the robot base frame and its side."""

    x: Length = Field(description="centre, robot base frame")
    y: Length = Field(description="centre, robot base frame")
    z: Length = Field(description="centre, robot base frame")
    side: Length = Field(gt=0.0, description="side of the cube")


class Report(SpecModel):
    """Certificate fields, and the evaluation tasks it shows (with simulated data, whose truth is known)."""

    tasks: list[Literal["grid_task", "iso9283"]] = Field(["grid_task"], description="Stone's grid task (7.2.1), the ISO 9283 cube")
    iso9283_cube: IsoCube | None = Field(None, description="where the ISO 9283 cube stands (needed by the iso9283 task)")
    certificate_number: str | None = Field(None, description="default: ARMCAL-<serial>-<date>-<spec hash>")
    customer: str | None = Field(None, description="printed on the certificate")
    operator: str | None = Field(None, description="who calibrated, printed with the signature lines")
    location: str | None = Field(None, description="where the calibration took place")
    notes: str | None = Field(None, description="free text printed on the certificate")
    template: str | None = Field(None, description="folder of your own certificate templates, searched first")
