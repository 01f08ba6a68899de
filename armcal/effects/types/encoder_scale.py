"""encoder_scale: theta = q (1 + scale), a joint's encoder gain error."""

from __future__ import annotations

from typing import Literal

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import EffectSpec
from armcal.spec_parts.base import Parameter, ScaleParam


class EncoderScale(JointEffect):
    """theta = q (1 + scale): a joint's encoder gain error."""

    type: Literal["encoder_scale"]
    scale: ScaleParam = Parameter(value=0.0)


class EncoderScaleType(EffectType):
    name = "encoder_scale"
    spec_model = EncoderScale
    compensated = True

    def fields(self, effect):
        return [("scale", "scale")]

    def candidates(self, kinematics, data, harmonic_orders):
        free = {e.name for e in kinematics.parameters.entries if e.free}  # six_parameter's free encoder scale is this effect already
        return [EffectSpec(self, joint=joint) for joint, name in enumerate(kinematics.joint_names, start=1) if f"{name}.k" not in free]

    def joint_deviation(self, effect, chain, value):
        return value("scale") * chain.q[effect.joint - 1]


ENCODER_SCALE = EncoderScaleType()
