"""A robot's chain as declared: plain values the spec builds from its ``robot`` section (spec_parts/robot.py's
``chain()``), so that the kinematics read no spec model. Values in internal units (mm, rad, 1)."""

from __future__ import annotations

from dataclasses import dataclass

from armcal.kinematics.masses import LumpedMass


@dataclass(frozen=True)
class DeclaredParameter:
    """One parameter as declared: its value, whether a fit may vary it, and its bounds."""

    value: float
    vary: bool = True
    min: float | None = None
    max: float | None = None


DeclaredPose = dict[str, DeclaredParameter]  # field (x, y, z, rx, ry, rz; a link's alpha, beta, gamma) -> parameter, the given ones in order


@dataclass(frozen=True)
class DeclaredJoint:
    name: str
    type: str  # revolute | prismatic
    parameters: DeclaredPose  # its convention's fields (kinematics/params.py's JOINT_FIELDS), a dh joint's beta where given
    limits: tuple[float, float]


@dataclass(frozen=True)
class DeclaredTarget:
    link: int  # 0: the base link, i: the link joint i moves
    pose: DeclaredPose  # x, y, z, and rx, ry, rz where it is a frame

    @property
    def is_frame(self) -> bool:
        return any(f in self.pose for f in ("rx", "ry", "rz"))


@dataclass(frozen=True)
class DeclaredChain:
    """A serial chain: its convention, joints, base and tool poses, targets, the maker's masses and the plausible
    deviations of identified values from the declared ones."""

    name: str
    convention: str  # dh | mdh | s_model | six_parameter
    joints: tuple[DeclaredJoint, ...]
    base: DeclaredPose
    tool: DeclaredPose
    links: tuple[DeclaredPose, ...]  # six_parameter: the n + 1 link transforms, base link first
    targets: dict[str, DeclaredTarget]
    masses: tuple[LumpedMass, ...]
    tolerance: dict[str, float]  # plausible deviation by kind: length, angle, scale

    @property
    def dof(self) -> int:
        return len(self.joints)

    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]
