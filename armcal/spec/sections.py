"""Smaller spec sections: data files, simulation, declared effects, diagnosis, report."""

from __future__ import annotations

import difflib
import math
import re
from typing import Annotated, Any, Literal, Union

from pydantic import ConfigDict, Field, ValidationInfo, model_validator

from armcal.spec.base import Angle, AngleParam, Length, LengthParam, Number, Parameter, ScaleParam, SpecModel, parameter_schema
from armcal.spec.robot import LinkMass, Offset

DEG = math.pi / 180.0

EFFECT_TYPES = (
    "encoder_scale",
    "gear_harmonic",
    "joint_compliance",
    "joint_coupling",
    "joint_bending",
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


MOMENT_KEY = re.compile(r"^m[xyz][1-9][0-9]*$")  # form moments: m<c><k>, axis c of frame F_k, link k (effects/library.py)


def _moment_products(cls, data: Any, info: ValidationInfo, moments: bool) -> Any:
    """Refuse unknown keys (only m<c><k> may be extra); where ``moments``, fill in the products left out with 0
    (free), from the robot's joints in the validation context: m<c><k> for links joint..n, or w (prismatic)."""
    if not isinstance(data, dict):
        return data
    for key in data:
        if key not in cls.model_fields and not MOMENT_KEY.match(str(key)):
            close = difflib.get_close_matches(str(key), list(cls.model_fields), n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(cls.model_fields) + " and m<c><k> such as mx3"
            raise ValueError(f"'{key}' is unknown in a {data.get('type')} effect: remove it or check its spelling ({hint})")
    kinds = (info.context or {}).get("joint_kinds", [])
    joint = data.get("joint")
    if not moments or not isinstance(joint, int) or not 1 <= joint <= len(kinds):
        return data
    out = dict(data)
    if kinds[joint - 1] == "angle":
        for k in range(joint, len(kinds) + 1):
            for c in "xyz":
                out.setdefault(f"m{c}{k}", 0.0)
    elif "w" in cls.model_fields:
        out.setdefault("w", 0.0)
    return out


def _moment_keys_schema(schema: dict) -> None:
    """The m<c><k> keys of the moments form in the JSON Schema: angle parameters, nothing else extra."""
    schema["patternProperties"] = {MOMENT_KEY.pattern: parameter_schema("angle")}
    schema["additionalProperties"] = False


class JointCompliance(JointEffect):
    """Joint deflection under gravity. form masses: compliance x the gravity torque of lumped masses. form moments:
    the torque is linear in the links' unknown first mass moments, and the products compliance x g x moment,
    keys m<c><k> (axis c = x, y, z of frame F_k, links k = joint..n; angle parameters, left out: free from 0),
    are identified with no masses given; a prismatic joint has the one product w."""

    model_config = ConfigDict(extra="allow", frozen=True, json_schema_extra=_moment_keys_schema)
    __pydantic_extra__: dict[str, AngleParam]  # the m<c><k> products (form moments)

    type: Literal["joint_compliance"]
    form: Literal["masses", "moments"] = Field(
        "masses",
        description="masses: one compliance times the torque of `masses`; moments: the products m<c><k> "
        "(compliance x g x first moment of link k about axis c of its frame), no masses needed",
    )
    compliance: Number = Field(0.0, description="rad per N m (form masses)")
    vary: bool = Field(True, description="identify the effect's parameters (else keep the values given)")
    masses: list[LinkMass] = Field([], description="form masses: lumped masses for the gravity torque (default: robot.masses, else 5 kg at each link frame's origin beyond the joint, assumed)")
    w: LengthParam | None = Field(None, description="form moments, prismatic joint: deflection along the axis under the weight beyond it, axis vertical")

    @model_validator(mode="before")
    @classmethod
    def _moment_products(cls, data: Any, info: ValidationInfo) -> Any:
        return _moment_products(cls, data, info, data.get("form") == "moments" if isinstance(data, dict) else False)


class JointBending(JointEffect):
    """The links beyond joint `joint` tilt about o_(joint-1), about the axes square to the joint, by a bending
    compliance times the moment of their weight there: keys m<c><k> as in joint_compliance's moments form
    (compliance x g x first moment of link k about axis c of its frame; angle parameters, left out: free from 0).
    Revolute joints."""

    model_config = ConfigDict(extra="allow", frozen=True, json_schema_extra=_moment_keys_schema)
    __pydantic_extra__: dict[str, AngleParam]  # the m<c><k> products

    type: Literal["joint_bending"]
    vary: bool = Field(True, description="identify the products (else keep the values given)")

    @model_validator(mode="before")
    @classmethod
    def _moment_products(cls, data: Any, info: ValidationInfo) -> Any:
        return _moment_products(cls, data, info, True)


class JointCoupling(JointEffect):
    """Joint `from` drives joint `joint` too: the chain sees q_joint + coefficient x q_from."""

    type: Literal["joint_coupling"]
    from_joint: int = Field(alias="from", ge=1, description="the driving joint, 1-based")
    coefficient: ScaleParam = Parameter(value=0.0)


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
        JointCoupling,
        JointBending,
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
    alpha: float = Field(0.001, gt=0.0, lt=1.0, description="family-wise false-positive rate of a round's score tests")
    max_rounds: int = Field(3, ge=0, description="effects added at most (one per round)")
    candidates: list[Literal[EFFECT_TYPES]] | None = Field(None, description="effect types tried (default: all the data allow)")  # type: ignore[valid-type]
    harmonic_orders: int = Field(3, ge=1, description="gear harmonics tried up to this order")
    holdout: Literal["kfold", "validation"] = Field(
        "kfold",
        description="data that must confirm an effect: k-fold cross-validation over the calibration poses (the validation set "
        "stays untouched for the final figures), or the validation set (its figures are then not independent)",
    )
    folds: int = Field(5, ge=2, description="k of the k-fold cross-validation")


class IsoCube(SpecModel):
    """Where the ISO 9283 test cube stands: its centre in the robot base frame and its side."""

    x: Length = Field(description="centre, robot base frame")
    y: Length = Field(description="centre, robot base frame")
    z: Length = Field(description="centre, robot base frame")
    side: Length = Field(gt=0.0, description="side of the cube")


ACCEPTANCE_STATISTICS = ("validation_rms", "validation_max", "validation_rms_3d", "validation_max_3d")


class Acceptance(SpecModel):
    """A tolerance the calibrated robot must meet on the held-out data, and the decision rule (ILAC-G8:2019)."""

    tolerance: Length = Field(gt=0.0, description="upper limit of the statistic")
    statistic: Literal[ACCEPTANCE_STATISTICS] = Field(  # type: ignore[valid-type]
        "validation_rms",
        description="the held-out figure judged, calibrated model: validation_rms / validation_max (per coordinate), "
        "validation_rms_3d / validation_max_3d (3D distance per pose, tracker)",
    )
    decision_rule: Literal["simple", "guarded"] = Field(
        "simple",
        description="simple: pass when the figure is at most the tolerance; guarded: when the figure plus its expanded "
        "uncertainty U (95 %: k from Student's t over the held-out poses) is (RMS statistics only)",
    )

    @model_validator(mode="after")
    def _guarded_needs_rms(self) -> "Acceptance":
        if self.decision_rule == "guarded" and "_rms" not in self.statistic:
            raise ValueError(f"guarded acceptance needs the figure's uncertainty, which armcal computes for RMS statistics only, not {self.statistic}; use decision_rule: simple")
        return self


class Report(SpecModel):
    """Certificate fields, and the evaluation tasks it shows (with simulated data, whose truth is known)."""

    tasks: list[Literal["grid_task", "iso9283"]] = Field(
        ["grid_task", "iso9283"],
        description="Stone's grid task (7.2.1; Table 7-1 where the robot reaches it, else scaled to the robot and placed in its "
        "workspace), the ISO 9283 cube",
    )
    iso9283_cube: IsoCube | None = Field(
        None, description="where the ISO 9283 cube stands; left out, armcal places the largest cube the robot reaches near its workspace's centre"
    )
    certificate_number: str | None = Field(None, description="default: ARMCAL-<serial>-<date>-<spec hash>")
    customer: str | None = Field(None, description="printed on the certificate")
    operator: str | None = Field(None, description="who calibrated, printed with the signature lines")
    location: str | None = Field(None, description="where the calibration took place")
    notes: str | None = Field(None, description="free text printed on the certificate")
    template: str | None = Field(None, description="folder of your own certificate templates, searched first")
