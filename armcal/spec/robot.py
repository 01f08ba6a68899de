"""The ``robot`` section: chain, convention, nominal parameters, base, tool, targets.

Conventions (one per kinematics/conventions.py function):
  dh             Denavit-Hartenberg, Stone (2.9): theta, d, a, alpha per joint
  mdh            Hayati's modified DH for near-parallel axes: DH then Rot(y, beta)
  s_model        Stone's S-Model (3.2): beta, d, a, alpha, gamma, b per joint
  six_parameter  Goswami's Sheth-Uicker model (3): links x, y, z + ZYX Euler
                 (alpha about z, beta about y, gamma about x); joints theta = theta0 + k q (2)
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import Field, ValidationInfo, WithJsonSchema, field_validator

from armcal import units
from armcal.spec.base import (
    AngleParam,
    Length,
    LengthParam,
    Parameter,
    ScaleParam,
    SpecModel,
    convert,
    fixed,
    normalize_parameter,
    parameter_schema,
    quantity_schema,
)

JointQuantity = Annotated[float, WithJsonSchema(quantity_schema("angle", "length"))]

JointType = Literal["revolute", "prismatic"]


def joint_kind(joint_type: str) -> str:
    """Kind of a joint's own variable: angle for revolute, length for prismatic."""
    return "angle" if joint_type == "revolute" else "length"


class Units(SpecModel):
    """Default units of every quantity written as a plain number in this spec."""

    length: Literal[tuple(units.LENGTH_UNITS)] = Field("mm", description="unit of plain lengths")  # type: ignore[valid-type]
    angle: Literal[tuple(units.ANGLE_UNITS)] = Field("deg", description="unit of plain angles")  # type: ignore[valid-type]

    def of(self, kind: str) -> str:
        """The spec's unit for lengths and angles; the internal unit of other kinds ("1" for counts)."""
        return {"length": self.length, "angle": self.angle}.get(kind) or units.INTERNAL_UNIT.get(kind, "1")


class Offset(SpecModel):
    """A translation x, y, z; left-out parts are fixed at 0."""

    x: LengthParam = fixed(0.0)
    y: LengthParam = fixed(0.0)
    z: LengthParam = fixed(0.0)


class Pose(Offset):
    """A rigid transform Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx); left-out parts are fixed at 0."""

    rx: AngleParam = fixed(0.0)
    ry: AngleParam = fixed(0.0)
    rz: AngleParam = fixed(0.0)


class Target(Offset):
    """A point (or, with any of rx/ry/rz, a frame) fixed on a link: sparker, sphere, reflector."""

    link: int = Field(ge=0, description="0 = base link, i = the link moved by joint i")
    rx: AngleParam | None = Field(None, description="orientation (with ry, rz): the target is a frame, not a point")
    ry: AngleParam | None = Field(None, description="see rx")
    rz: AngleParam | None = Field(None, description="see rx")

    @property
    def is_frame(self) -> bool:
        return any(r is not None for r in (self.rx, self.ry, self.rz))


class LinkMass(SpecModel):
    """A lumped mass on a link for gravity torques: kg and centre of mass in the link frame."""

    link: int = Field(ge=1, description="link carrying the mass")
    mass: float = Field(gt=0.0, description="kg")
    x: Length = Field(0.0, description="centre of mass, link frame")
    y: Length = Field(0.0, description="centre of mass, link frame")
    z: Length = Field(0.0, description="centre of mass, link frame")


class JointBase(SpecModel):
    """What every joint has: a name, a type and limits in the joint's unit."""

    name: str | None = Field(None, description="joint name (default j1, j2, ...)")
    type: JointType = Field("revolute", description="revolute or prismatic")
    limits: tuple[JointQuantity, JointQuantity] = Field(description="lower and upper joint limit, joint unit")

    @field_validator("limits", mode="before")
    @classmethod
    def _limits_in_joint_unit(cls, raw: Any, info: ValidationInfo) -> Any:
        if not isinstance(raw, (list, tuple)) or len(raw) != 2:
            raise ValueError("limits must be a list of two values [lower, upper]")
        kind = joint_kind(info.data.get("type", "revolute"))
        low, high = (convert(v, info, kind) for v in raw)
        if low >= high:
            raise ValueError("the lower limit must be below the upper limit")
        return (low, high)


class DHJoint(JointBase):
    """Denavit-Hartenberg joint, Stone (2.9); theta (revolute) or d (prismatic) is the offset at q = 0."""

    theta: AngleParam
    d: LengthParam
    a: LengthParam
    alpha: AngleParam
    beta: AngleParam | None = Field(
        None,
        description="Hayati's tilt Rot(y, beta) after Rot(x, alpha), for an axis parallel to the next one; "
        "left out, it is added (free, at 0) wherever the two axes are parallel, and d is then held",
    )


class MDHJoint(DHJoint):
    """Hayati's modified DH joint: (2.9) followed by Rot(y, beta); use d fixed at 0 for near-parallel axes."""

    beta: AngleParam = Field(fixed(0.0), description="Hayati's tilt Rot(y, beta) after Rot(x, alpha)")


class SModelJoint(JointBase):
    """S-Model joint, Stone (3.2); beta (revolute) or d (prismatic) is the offset at q = 0."""

    beta: AngleParam
    d: LengthParam
    a: LengthParam
    alpha: AngleParam
    gamma: AngleParam = fixed(0.0)
    b: LengthParam = fixed(0.0)


class SixParameterJoint(JointBase):
    """Goswami's joint with encoder offset and scale, theta = theta0 + k q (2)."""

    theta0: Annotated[Parameter, WithJsonSchema(parameter_schema("angle", "length"))] = fixed(0.0)
    k: ScaleParam = fixed(1.0)

    @field_validator("theta0", mode="before")
    @classmethod
    def _offset_in_joint_unit(cls, raw: Any, info: ValidationInfo) -> Any:
        return normalize_parameter(raw, info, joint_kind(info.data.get("type", "revolute")))


class SixParameterLink(Offset):
    """Goswami's link transform Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma) (3)."""

    alpha: AngleParam = fixed(0.0)
    beta: AngleParam = fixed(0.0)
    gamma: AngleParam = fixed(0.0)


class RobotBase(SpecModel):
    """Identity, units, base and tool transforms and targets common to all conventions."""

    name: str = Field(description="robot name, printed on the certificate")
    serial: str = Field(description="serial number of this very robot, printed on the certificate")
    model: str | None = Field(None, description="robot model (type designation)")
    units: Units = Field(Units(), description="units of every plain number in this spec")
    base: Pose = Field(Pose(), description="robot base frame in the mounting (world) frame; fixed at 0 unless given")
    tool: Pose = Field(Pose(), description="tool frame on the last link; fixed at 0 unless given")
    targets: dict[str, Target] = Field({}, description="named points or frames on links: sparkers, spheres, reflectors")
    masses: list[LinkMass] = Field(
        [],
        description="the robot's mass layout (the maker's data): the gravity torque of compliance where an effect names "
        "no masses, and the diagnosis' compliance candidates then identify one compliance per joint; without it they "
        "identify the links' mass moments (form moments)",
    )

    @property
    def dof(self) -> int:
        return len(self.joints)  # type: ignore[attr-defined]

    def joint_names(self) -> list[str]:
        return [j.name or f"j{i}" for i, j in enumerate(self.joints, start=1)]  # type: ignore[attr-defined]


class DHRobot(RobotBase):
    convention: Literal["dh"]
    joints: list[DHJoint] = Field(min_length=1)


class MDHRobot(RobotBase):
    convention: Literal["mdh"]
    joints: list[MDHJoint] = Field(min_length=1)


class SModelRobot(RobotBase):
    convention: Literal["s_model"]
    joints: list[SModelJoint] = Field(min_length=1)


class SixParameterRobot(RobotBase):
    convention: Literal["six_parameter"]
    joints: list[SixParameterJoint] = Field(min_length=1)
    links: list[SixParameterLink] = Field(min_length=2, description="n + 1 link transforms, base link first")


Robot = Annotated[
    Union[DHRobot, MDHRobot, SModelRobot, SixParameterRobot],
    Field(discriminator="convention"),
]
