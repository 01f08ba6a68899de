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

from collections.abc import Iterator
from datetime import date
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import Field, ValidationInfo, WithJsonSchema, WrapValidator, field_validator

from armcal.support.errors import shown_value
from armcal.spec_parts.base import LengthParam, SpecModel, convert, quantity_schema

AUTO = "auto"  # a noise sigma estimated from the data


def is_auto(value: Any) -> bool:
    return isinstance(value, str) and value.strip() == AUTO


def _sigma_or_auto(kind: str):
    """A positive quantity of ``kind``, or ``auto``."""

    def validate(value: Any, handler, info: ValidationInfo) -> float | str:
        if is_auto(value):
            return AUTO
        try:
            sigma = convert(value, info, kind)
        except ValueError as exc:
            raise ValueError(f"{exc} (or write auto, to estimate it from the data)") from None
        if not sigma > 0:
            raise ValueError(f"a noise sigma must be above 0 (or auto, to estimate it from the data), got {shown_value(value)}")
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


Loc = tuple[str | int, ...]  # the path of a field in the spec


class DeviceSpec(SpecModel):
    """What every device section shares: its identity (``instrument``), which noise sigmas are estimated from the
    data, and by which groups (each device declares ``noise``, ``noise_groups`` and ``estimate_noise``); and what the
    rest of armcal may ask of an instrument before any model is built: the procedures and effects it takes, what
    its readings are, its cross-references and its description."""

    instrument: Instrument | None = Field(None, description="the instrument's identity and calibration, printed on the certificate")

    procedures: ClassVar[tuple[str, ...]] = ("poses",)  # the procedure types that plan its campaigns
    instrument_effects: ClassVar[tuple] = ()  # the instrument-side effect types (effects/effect_type.py) that act on its readings
    reading_kind: ClassVar[str] = "length"  # the kind of its readings residuals are summarised in (length, angle)
    fixes_positions: ClassVar[bool] = False  # its readings fix a target's position (Stone's circle-point features)
    reads_positions: ClassVar[bool] = False  # its readings are a target's x, y, z in its own frame (rigid registration)
    locates_targets: ClassVar[bool] = False  # its readings locate each target it sees in space (a tool centre point)
    held_out_metric: ClassVar[str] = "3D position error of the targets (instrument frame)"

    def seen_targets(self) -> list[str]:
        """The robot targets it measures (those its ``target_field`` names)."""
        named = getattr(self, self.target_field, ())
        return [named] if isinstance(named, str) else list(named)

    def sees_orientation(self) -> bool:
        """Whether its readings include the orientation of the target's frame."""
        return False

    def check(self, spec) -> Iterator[tuple[Loc, str]]:
        """Cross-reference problems of the device section in ``spec`` (targets that are not the robot's...)."""
        one = isinstance(getattr(self, self.target_field, ()), str)  # a field that names one target (a probe, a ball)
        for i, name in enumerate(self.seen_targets()):
            if name not in spec.robot.targets:
                known = ", ".join(spec.robot.targets) or "none defined"
                loc = ("device", self.target_field) if one else ("device", self.target_field, i)
                yield loc, f"{self.target_field if one else self.target_field[:-1]} {shown_value(name)} is not a robot target (targets: {known})"

    target_field: ClassVar[str] = "targets"  # the field that names the robot targets it measures (a list, or one)

    def check_procedure(self, procedure, loc: Loc) -> Iterator[tuple[Loc, str]]:
        """Problems of a procedure of its own (``loc``: where the procedure is)."""
        if procedure.type == "poses" and (procedure.file is None) == (procedure.count is None):
            yield loc, "give either a pose file (file) or a number of random poses (count)"

    def check_effect(self, effect, loc: Loc) -> Iterator[tuple[Loc, str]]:
        """Problems of an instrument-side effect of ``instrument_effects`` (a microphone or pivot it does not have)."""
        return iter(())

    def describe(self, length) -> tuple[str, list[str]]:
        """What the certificate calls the instrument, and its details; ``length`` shows a length with its unit."""
        raise NotImplementedError

    def base_frame_free(self, free: set[str]) -> bool:
        """Whether its readings fix the robot's base frame only up to a rigid motion, given the ``free`` parameters:
        its own placement is identified with the robot (a free robot_base), so a task's frame is taught (evaluate/grid.py)."""
        return any(name.startswith("robot_base.") for name in free)

    def parameter_location(self, name: str) -> list[str]:
        """The path in the spec of one of its model's parameters, e.g. robot_base.x -> device, robot_base, x."""
        head, _, field = name.rpartition(".")
        if head != "robot_base":
            raise ValueError(f"{shown_value(name)} is not a parameter of a {self.type}")
        return ["device", "robot_base", field]

    def out_of_range(self, length) -> tuple[str, str, str]:
        """Where a reading it cannot take lies, the reason's name, and the spec keys that set that range."""
        return "outside the instrument's range", "instrument range", "the device's range keys"

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



