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

from armcal.support import units
from armcal.kinematics.chain import DeclaredChain, DeclaredJoint, DeclaredTarget
from armcal.kinematics.masses import LumpedMass
from armcal.kinematics.params import LINK_FIELDS, joint_kind
from armcal.spec_parts.base import (
    Angle,
    AngleParam,
    Length,
    LengthParam,
    Parameter,
    ScaleParam,
    SpecModel,
    convert,
    declared_pose,
    fixed,
    normalize_parameter,
    parameter_schema,
    quantity_schema,
)

JointQuantity = Annotated[float, WithJsonSchema(quantity_schema("angle", "length"))]

JointType = Literal["revolute", "prismatic"]


class Units(SpecModel):
    """Default units of every quantity written as a plain number in this spec."""

    length: Literal[tuple(units.LENGTH_UNITS)] = Field("mm", description="unit of plain lengths")  # type: ignore[valid-type]
    angle: Literal[tuple(units.ANGLE_UNITS)] = Field("deg", description="unit of plain angles")  # type: ignore[valid-type]

    def of(self, kind: str) -> str:
        """The spec's unit for lengths and angles; the internal unit of other kinds ("1" for counts)."""
        return {"length": self.length, "angle": self.angle}.get(kind) or units.INTERNAL_UNIT.get(kind, "1")


class Offset(SpecModel):
    """A translation x, y, z; left-out parts are fixed at 0."""

    x: LengthParam = Field(fixed(0.0), description="translation along the x axis of the frame it is given in")
    y: LengthParam = Field(fixed(0.0), description="translation along the y axis of the frame it is given in")
    z: LengthParam = Field(fixed(0.0), description="translation along the z axis of the frame it is given in")


class Pose(Offset):
    """A rigid transform Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx); left-out parts are fixed at 0."""

    rx: AngleParam = Field(fixed(0.0), description="rotation about x, applied last: Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx)")
    ry: AngleParam = Field(fixed(0.0), description="rotation about y, after rz and before rx: Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx)")
    rz: AngleParam = Field(fixed(0.0), description="rotation about z, applied first after the translation: Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx)")


class Target(Offset):
    """A point (or, with any of rx/ry/rz, a frame) fixed on a link: sparker, sphere, reflector."""

    link: int = Field(ge=0, description="0 = base link, i = the link moved by joint i")
    x: LengthParam = Field(fixed(0.0), description="the point's x coordinate in the frame of its link")
    y: LengthParam = Field(fixed(0.0), description="the point's y coordinate in the frame of its link")
    z: LengthParam = Field(fixed(0.0), description="the point's z coordinate in the frame of its link")
    rx: AngleParam | None = Field(
        None, description="orientation (with ry, rz; as in a pose, Rot(z, rz) Rot(y, ry) Rot(x, rx)): the target is a frame, not a point"
    )
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

    theta: AngleParam = Field(
        description="rotation about z_(i-1) that turns x_(i-1) onto x_i, Rot(z, theta) in Stone (2.9) "
        "A_i = Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha); a revolute joint adds its reading q"
    )
    d: LengthParam = Field(
        description="offset along z_(i-1) from x_(i-1) to the common normal x_i, Trans(0, 0, d) in Stone (2.9); a prismatic joint adds its reading q"
    )
    a: LengthParam = Field(description="link length: distance along the common normal x_i from axis z_(i-1) to axis z_i, Trans(a, 0, 0) in Stone (2.9)")
    alpha: AngleParam = Field(description="link twist: angle about x_i from axis z_(i-1) to axis z_i, Rot(x, alpha) in Stone (2.9)")
    beta: AngleParam | None = Field(
        None,
        description="Hayati's tilt Rot(y, beta) after Rot(x, alpha), for an axis parallel to the next one; "
        "left out, it is added (free, at 0) wherever the two axes are parallel, and d is then held",
    )


class MDHJoint(DHJoint):
    """Hayati's modified DH joint: (2.9) followed by Rot(y, beta); use d fixed at 0 for near-parallel axes."""

    beta: AngleParam = Field(fixed(0.0), description="Hayati's tilt: rotation about y_i after Rot(x, alpha), (2.9) then Rot(y, beta)")


class SModelJoint(JointBase):
    """S-Model joint, Stone (3.2); beta (revolute) or d (prismatic) is the offset at q = 0."""

    beta: AngleParam = Field(
        description="rotation about z_(i-1), Rot(z, beta) in Stone (3.2) "
        "B_i = Rot(z, beta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha) Rot(z, gamma) Trans(0, 0, b); a revolute joint adds its reading q"
    )
    d: LengthParam = Field(description="translation along z_(i-1), Trans(0, 0, d) in Stone (3.2); a prismatic joint adds its reading q")
    a: LengthParam = Field(description="translation along the new x axis, Trans(a, 0, 0) in Stone (3.2): distance between the joint axes")
    alpha: AngleParam = Field(description="twist about the new x axis, Rot(x, alpha) in Stone (3.2): angle between the joint axes")
    gamma: AngleParam = Field(fixed(0.0), description="rotation about the new z axis, Rot(z, gamma) in Stone (3.2): places the link frame's x axis freely")
    b: LengthParam = Field(fixed(0.0), description="translation along the new z axis, Trans(0, 0, b) in Stone (3.2): places the link frame's origin freely")


class SixParameterJoint(JointBase):
    """Goswami's joint with encoder offset and scale, theta = theta0 + k q (2)."""

    theta0: Annotated[Parameter, WithJsonSchema(parameter_schema("angle", "length"))] = Field(
        fixed(0.0), description="encoder offset: the joint value theta (angle, or length for a prismatic joint) at reading q = 0, theta = theta0 + k q (2)"
    )
    k: ScaleParam = Field(fixed(1.0), description="encoder scale: joint value per unit of reading, theta = theta0 + k q (2); 1 for an exact encoder")

    @field_validator("theta0", mode="before")
    @classmethod
    def _offset_in_joint_unit(cls, raw: Any, info: ValidationInfo) -> Any:
        return normalize_parameter(raw, info, joint_kind(info.data.get("type", "revolute")))


class SixParameterLink(Offset):
    """Goswami's link transform Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma) (3)."""

    x: LengthParam = Field(fixed(0.0), description="translation along x of the preceding frame, Trans(x, y, z) in (3)")
    y: LengthParam = Field(fixed(0.0), description="translation along y of the preceding frame, Trans(x, y, z) in (3)")
    z: LengthParam = Field(fixed(0.0), description="translation along z of the preceding frame, Trans(x, y, z) in (3)")
    alpha: AngleParam = Field(fixed(0.0), description="first ZYX Euler angle: rotation about z after the translation, Rot(z, alpha) in (3)")
    beta: AngleParam = Field(fixed(0.0), description="second ZYX Euler angle: rotation about the new y, Rot(y, beta) in (3)")
    gamma: AngleParam = Field(fixed(0.0), description="third ZYX Euler angle: rotation about the new x, Rot(x, gamma) in (3); the next joint turns about the resulting z")


class Tolerance(SpecModel):
    """How far an identified robot value may lie from its nominal value and still be plausible."""

    length: Length = Field("10 mm", validate_default=True, gt=0.0, description="plausible deviation of an identified length from its nominal value")
    angle: Angle = Field("2 deg", validate_default=True, gt=0.0, description="plausible deviation of an identified angle from its nominal value")
    scale: float = Field(
        0.01, gt=0.0, lt=1.0,
        description="plausible deviation of an identified encoder scale k (six_parameter joints) from its nominal value, "
        "a ratio: 0.01 is 1 %, eight times the largest deviation of Goswami et al.'s identified encoder factors (0.998821, Table II)",
    )


class UrdfLink(SpecModel):
    """A URDF link moved by joint i: its name, and its frame in the frame F_(i-1) Rot(z, q_i) that joint i turns."""

    name: str = Field(description="the link's name in the URDF")
    z: Length = Field(0.0, description="the link frame's origin along joint i's axis (a URDF link's origin lies on its joint's axis)")
    rz: Angle = Field(0.0, description="the link frame's orientation: Trans(0, 0, z) Rot(z, rz) Rot(y, ry) Rot(x, rx)")
    ry: Angle = Field(0.0, description="see rz")
    rx: Angle = Field(0.0, description="see rz")


class UrdfNames(SpecModel):
    """The names (and link frames) of the URDF a chain came from, written back by armcal export --format urdf."""

    base: str = Field("world", description="the URDF link of the spec's world frame (import-urdf's --base)")
    tool: str = Field("tool0", description="the URDF link of the tool frame (import-urdf's --tip)")
    links: list[UrdfLink] = Field(
        [], description="one per joint, in order: the link it moves (default link_1 .. link_n, frame F_(i-1) Rot(z, q_i))"
    )


class RobotBase(SpecModel):
    """Identity, units, base and tool transforms and targets common to all conventions."""

    name: str = Field(description="robot name, printed on the certificate")
    serial: str = Field(description="serial number of this very robot, printed on the certificate")
    model: str | None = Field(None, description="robot model (type designation)")
    units: Units = Field(Units(), description="units of every plain number in this spec")
    base: Pose = Field(Pose(), description="robot base frame in the mounting (world) frame; fixed at 0 unless given")
    tool: Pose = Field(Pose(), description="tool frame on the last link; fixed at 0 unless given")
    targets: dict[str, Target] = Field({}, description="named points or frames on links: sparkers, spheres, reflectors")
    tolerance: Tolerance | None = Field(
        None,
        description="plausible deviations of identified values from nominal (length, angle, encoder scale); a value beyond them is "
        "reported as implausible. Default when not given: 10 mm, 2 deg and 0.01 (encoder scales)",
    )
    urdf: UrdfNames | None = Field(
        None,
        description="the names of the URDF the chain was imported from (import-urdf writes them): export --format urdf "
        "names its links so, and places each link's frame as the URDF did, so meshes and controller configs attach",
    )
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

    @property
    def plausible_deviations(self) -> Tolerance:
        """``tolerance``, else its defaults."""
        return self.tolerance or Tolerance()

    def chain(self) -> DeclaredChain:
        """The chain as the kinematics take it (kinematics/chain.py): plain values in internal units."""
        tolerance = self.plausible_deviations
        return DeclaredChain(
            name=self.name,
            convention=self.convention,  # type: ignore[attr-defined]
            joints=tuple(
                DeclaredJoint(name, joint.type, {f: p.declared() for f, p in joint if isinstance(p, Parameter)}, joint.limits)
                for name, joint in zip(self.joint_names(), self.joints)  # type: ignore[attr-defined]
            ),
            base=declared_pose(self.base),
            tool=declared_pose(self.tool),
            links=tuple(declared_pose(link, LINK_FIELDS) for link in getattr(self, "links", ())),
            targets={name: DeclaredTarget(target.link, declared_pose(target)) for name, target in self.targets.items()},
            masses=tuple(LumpedMass(m.link, m.mass, (m.x, m.y, m.z)) for m in self.masses),
            tolerance={"length": tolerance.length, "angle": tolerance.angle, "scale": tolerance.scale},
        )

    def link_names(self) -> list[str]:
        """The URDF names of the world, links 1..n and the tool: robot.urdf's, else world, link_1 .. link_n, tool0."""
        names = self.urdf or UrdfNames()
        links = [link.name for link in names.links] or [f"link_{i}" for i in range(1, self.dof + 1)]
        return [names.base, *links, names.tool]


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
