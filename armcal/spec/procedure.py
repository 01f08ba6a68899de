"""The ``procedure`` section: which poses are measured, discriminated on ``type``."""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import Field, ValidationInfo, WithJsonSchema, field_validator

from armcal.spec_parts.base import Angle, Length, SpecModel, convert, quantity_schema


def joint_values(raw: Any, info: ValidationInfo) -> Any:
    """A list of joint values in each joint's unit (kinds from the loader's context)."""
    if not isinstance(raw, list):
        return raw
    kinds = (info.context or {}).get("joint_kinds", [])
    return [convert(v, info, kinds[i] if i < len(kinds) else "angle") for i, v in enumerate(raw)]



MAX_PLANNED = 200_000  # poses of one procedure: as many samples as a data file may hold (dataio/reader.py)

class CirclePoint(SpecModel):
    """Stone's circle-point sweeps (4.5, 6.4): joint i swept with joints 1..i-1 at the signature."""

    type: Literal["circle_point"]
    signature: list[Annotated[float, WithJsonSchema(quantity_schema("angle", "length"))]] = Field(description="signature configuration, one value per joint (joint units)")
    targets: list[str] = Field(description="target swept by each joint, in joint order (target i on link i)")
    points_per_joint: Annotated[int, Field(ge=1, le=MAX_PLANNED)] | list[Annotated[int, Field(ge=1, le=MAX_PLANNED)]] = Field(
        20, description="N_i, one number for all joints or one per joint"
    )
    averaging: int = Field(10, ge=1, le=1000, description="N_avg readings averaged per position")

    @field_validator("signature", mode="before")
    @classmethod
    def _in_joint_units(cls, raw: Any, info: ValidationInfo) -> Any:
        return joint_values(raw, info)


class Pairing(SpecModel):
    pivot: str = Field(description="chuck the bar is seated in (from device.pivots)")
    sphere: str = Field(description="sphere on the robot (from device.spheres)")


class Shells(SpecModel):
    """Goswami's hemispherical shells: latitude/longitude points around each pivot."""

    type: Literal["shells"]
    pairings: list[Pairing] = Field(min_length=1, max_length=100, description="pivot/sphere pairs, one shell each (Goswami Table I)")
    latitudes: list[Angle] = Field(min_length=1, max_length=180, description="elevation of each ring above the pivot")
    longitudes: int = Field(12, ge=1, le=3600, description="points per ring")
    extension: str | None = Field(None, description="extension rod fitted (name from device.extension_rods)")
    radius: Length | None = Field(None, description="shell radius; default: bar length at mid-travel")


class Poses(SpecModel):
    """Poses from a CSV file of joint values, or ``count`` random poses within limits."""

    type: Literal["poses"]
    file: str | None = Field(None, description="CSV of joint values q1..qN, relative to the spec; a ball-bar's also names each pose's bar (pivot, sphere, optional extension), as armcal plan writes it")
    count: int | None = Field(None, ge=1, le=MAX_PLANNED, description="number of random poses within the joint limits (without file)")
    seed: int = Field(0, ge=0, description="seed of the random poses")


Procedure = Annotated[Union[CirclePoint, Shells, Poses], Field(discriminator="type")]
