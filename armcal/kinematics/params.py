"""The named parameter vector of a robot: names, units, nominal values, free mask, bounds.

Names are ``base.x``, ``j2.a`` (joint parameters), ``L3.gamma`` (six_parameter
links), ``tool.rz`` and ``<target>.x``; values are in mm, rad or 1.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from armcal.kinematics.chain import DeclaredChain, DeclaredParameter, DeclaredPose
from armcal.kinematics.parallel_axes import parallel_axes
from armcal.support.units import INTERNAL_UNIT

POSE_FIELDS = ("x", "y", "z", "rx", "ry", "rz")
LINK_FIELDS = ("x", "y", "z", "alpha", "beta", "gamma")
JOINT_FIELDS = {
    "dh": ("theta", "d", "a", "alpha"),
    "mdh": ("theta", "d", "a", "alpha", "beta"),
    "s_model": ("beta", "d", "a", "alpha", "gamma", "b"),
    "six_parameter": ("theta0", "k"),
}
_LENGTHS = {"x", "y", "z", "d", "a", "b"}
_SCALES = {"k"}


def joint_kind(joint_type: str) -> str:
    """Kind of a joint's own variable: angle for revolute, length for prismatic."""
    return "angle" if joint_type == "revolute" else "length"


def field_kind(field: str, joint_type: str = "revolute") -> str:
    """length, angle or scale for a parameter field (theta0 follows the joint type)."""
    if field == "theta0":
        return joint_kind(joint_type)
    if field in _LENGTHS:
        return "length"
    return "scale" if field in _SCALES else "angle"


@dataclass(frozen=True)
class ParameterInfo:
    name: str
    kind: str  # length | angle | scale
    nominal: float
    free: bool
    lower: float | None
    upper: float | None
    reason: str = ""  # why the model holds a parameter the spec leaves free (e.g. parallel axes)
    role: str = "chain"  # chain | target (on a link) | device (the instrument's) | effect
    tolerance: float | None = None  # plausible deviation from nominal (robot.tolerance, internal unit); None: not judged

    @property
    def unit(self) -> str:
        return INTERNAL_UNIT[self.kind]


@dataclass(frozen=True)
class ParameterSet:
    """Ordered parameters of a model."""

    entries: tuple[ParameterInfo, ...]

    @property
    def names(self) -> list[str]:
        return [e.name for e in self.entries]

    @property
    def nominal(self) -> np.ndarray:
        return np.array([e.nominal for e in self.entries])

    @property
    def free(self) -> np.ndarray:
        return np.array([e.free for e in self.entries], dtype=bool)

    def __len__(self) -> int:
        return len(self.entries)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def values(self, p: np.ndarray) -> dict[str, float]:
        return dict(zip(self.names, np.asarray(p, dtype=float)))

    def symbols(self, vector: ca.SX) -> dict[str, ca.SX]:
        """Name -> element of a symbol vector of these parameters."""
        return dict(zip(self.names, ca.vertsplit(vector)))


def parameter_group(entry: ParameterInfo) -> tuple[str, str] | None:
    """The group a robot parameter is freed with and the group's label: the base's or the tool's pose, a target's
    position; None: a parameter on its own."""
    head = entry.name.rpartition(".")[0]
    if entry.role == "target":
        return head, f"target {head}'s position"
    return {"base": (head, "the robot's base pose"), "tool": (head, "the tool frame")}.get(head)


def parameter_entry(name: str, kind: str, parameter: DeclaredParameter) -> ParameterInfo:
    """The entry of one declared parameter."""
    return ParameterInfo(name, kind, parameter.value, parameter.vary, parameter.min, parameter.max)


def pose_entries(prefix: str, pose: DeclaredPose) -> list[ParameterInfo]:
    """Entries ``prefix.field`` of a pose's (a point's, a link's) declared parameters, in its order."""
    return [parameter_entry(f"{prefix}.{field}", field_kind(field), parameter) for field, parameter in pose.items()]


def point_entries(prefix: str, points: dict[str, DeclaredPose]) -> list[ParameterInfo]:
    """Entries ``prefix.name.x|y|z`` of named points (an instrument's pivots, sockets, microphones), in their order."""
    return [entry for name, point in points.items() for entry in pose_entries(f"{prefix}.{name}", point)]


def parameter_set(chain: DeclaredChain) -> ParameterSet:
    """All parameters of a declared chain in chain order: base, joints (and links), tool, targets.

    A ``dh`` joint has Hayati's beta where the spec gives one or its axis is parallel to
    the next (kinematics/parallel_axes.py), with its d then held."""
    entries = pose_entries("base", chain.base)
    fields = JOINT_FIELDS[chain.convention]
    parallel = {p.joint: p for p in parallel_axes(chain)}
    for i, joint in enumerate(chain.joints, start=1):
        if chain.convention == "six_parameter":
            entries += pose_entries(f"L{i}", chain.links[i - 1])
        joint_entries = [parameter_entry(f"{joint.name}.{f}", field_kind(f, joint.type), joint.parameters[f]) for f in fields]
        beta = joint.parameters.get("beta")
        if chain.convention == "dh" and (beta is not None or i in parallel):
            if beta is None:  # a parallel axis: Hayati's beta, free from 0
                joint_entries.append(ParameterInfo(f"{joint.name}.beta", "angle", 0.0, True, None, None))
            else:
                joint_entries.append(parameter_entry(f"{joint.name}.beta", "angle", beta))
        if i in parallel and parallel[i].d_held:
            d = fields.index("d")
            joint_entries[d] = replace(joint_entries[d], free=False, reason=parallel[i].reason)
        entries += joint_entries
    if chain.convention == "six_parameter":
        entries += pose_entries(f"L{chain.dof + 1}", chain.links[chain.dof])
    entries += pose_entries("tool", chain.tool)
    for name, target in chain.targets.items():
        entries += [replace(e, role="target") for e in pose_entries(name, target.pose)]
    return ParameterSet(tuple(replace(e, tolerance=chain.tolerance.get(e.kind)) for e in entries))
