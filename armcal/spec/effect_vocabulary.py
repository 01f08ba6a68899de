"""The effect vocabulary of specs (``effects``, ``simulate.effects``): one model per effect type, by ``type``.

What each effect does to the readings is in effects/ (library.py: its parameters, measurement.py: its place in h);
docs/effects.md is the user's reference.
"""

from __future__ import annotations

import difflib
import math
import re
from typing import Annotated, Any, Literal, Union

from pydantic import ConfigDict, Field, ValidationInfo, model_validator

from armcal.support.errors import shown_key, shown_value
from armcal.spec_parts.base import AngleParam, LengthParam, Number, Parameter, ScaleParam, SpecModel, parameter_schema
from armcal.spec_parts.robot import LinkMass, Offset

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
            raise ValueError(f"{shown_key(key, quoted=True)} is unknown in a {shown_value(data.get('type'))} effect: remove it or check its spelling ({hint})")
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
