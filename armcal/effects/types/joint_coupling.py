"""joint_coupling: joint ``from`` drives joint ``joint`` too, which sees q_joint + coefficient x q_from.

Proposed for neighbouring joints, in both directions, and among the wrist's joints (the last three of an arm of five
or more): a belt, a parallelogram or a ball-screw spline couples joints next to each other, a wrist's gear train
couples its three axes; a coupling across the arm (joint 1 driving joint 5) has no mechanism, and every extra
candidate costs the others power under Holm's correction.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import EffectSpec
from armcal.spec_parts.base import Parameter, ScaleParam


class JointCoupling(JointEffect):
    """Joint `from` drives joint `joint` too: the chain sees q_joint + coefficient x q_from."""

    type: Literal["joint_coupling"]
    from_joint: int = Field(alias="from", ge=1, description="the driving joint, 1-based")
    coefficient: ScaleParam = Parameter(value=0.0)


def coupling_pairs(dof: int) -> list[tuple[int, int]]:
    """(from, joint) pairs proposed: neighbours both ways, and the wrist's joints among themselves."""
    wrist = set(range(dof - 2, dof + 1)) if dof >= 5 else set()
    return [(i, j) for j in range(1, dof + 1) for i in range(1, dof + 1) if i != j and (abs(i - j) == 1 or {i, j} <= wrist)]


class JointCouplingType(EffectType):
    name = "joint_coupling"
    spec_model = JointCoupling
    compensated = True

    def fields(self, effect):
        return [("coefficient", "scale")]

    def source(self, entry):
        return f"q{entry.from_joint}"

    def source_joint(self, effect):
        return int(effect.source[1:])

    def spec_keys(self, effect):
        return {"from": effect.source_joint}

    def candidates(self, kinematics, data, harmonic_orders):
        return [coupling(joint, i) for i, joint in coupling_pairs(kinematics.dof)]

    def joint_deviation(self, effect, chain, value):
        return value("coefficient") * chain.q[effect.source_joint - 1]


JOINT_COUPLING = JointCouplingType()


def coupling(joint: int, source_joint: int, **rest) -> EffectSpec:
    """Joint ``source_joint`` drives joint ``joint``."""
    return EffectSpec(JOINT_COUPLING, joint=joint, source=f"q{source_joint}", **rest)
