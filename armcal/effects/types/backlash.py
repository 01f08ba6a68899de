"""backlash: joint error = half_width x approach direction (the dir columns)."""

from __future__ import annotations

from typing import Literal

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import EffectSpec
from armcal.spec_parts.base import AngleParam, Parameter


class Backlash(JointEffect):
    """Joint error = half_width x approach direction (needs dir columns)."""

    type: Literal["backlash"]
    half_width: AngleParam = Parameter(value=0.0)


class BacklashType(EffectType):
    name = "backlash"
    spec_model = Backlash

    def fields(self, effect):
        return [("half_width", "angle")]

    def needs(self, effect):
        return {"dir"}

    def candidates(self, kinematics, data, harmonic_orders):
        return [EffectSpec(self, joint=joint) for joint in range(1, kinematics.dof + 1)] if "dir" in data.extras else []

    def joint_deviation(self, effect, chain, value):
        return value("half_width") * chain.x[effect.joint - 1]


BACKLASH = BacklashType()
