"""gear_harmonic: a sinusoidal transmission error of one order (Whitney & Lozinski), A sin(h r q) + B cos(h r q)."""

from __future__ import annotations

from typing import Literal

import casadi as ca
from pydantic import Field

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import EffectSpec
from armcal.spec_parts.base import AngleParam, Parameter


class GearHarmonic(JointEffect):
    """Sinusoidal transmission error of one order (Whitney & Lozinski): sin and cos amplitudes."""

    type: Literal["gear_harmonic"]
    order: int = Field(ge=1, description="harmonic order: cycles per joint (or motor) revolution")
    ratio: float = Field(1.0, gt=0.0, description="gear ratio for motor-side harmonics (1 = joint side)")
    sin: AngleParam = Parameter(value=0.0)
    cos: AngleParam = Parameter(value=0.0)


class GearHarmonicType(EffectType):
    name = "gear_harmonic"
    spec_model = GearHarmonic
    compensated = True

    def fields(self, effect):
        return [("sin", "angle"), ("cos", "angle")]

    def spec_keys(self, effect):
        return {"ratio": effect.ratio} if effect.ratio != 1.0 else {}

    def candidates(self, kinematics, data, harmonic_orders):
        return [EffectSpec(self, joint=joint, order=h) for joint in range(1, kinematics.dof + 1) for h in range(1, harmonic_orders + 1)]

    def joint_deviation(self, effect, chain, value):
        phase = effect.order * effect.ratio * chain.q[effect.joint - 1]
        return value("sin") * ca.sin(phase) + value("cos") * ca.cos(phase)


GEAR_HARMONIC = GearHarmonicType()
