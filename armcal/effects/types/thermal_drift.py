"""thermal_drift: every length of the robot scaled by 1 + coefficient x (temperature - reference), or x time."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from armcal.effects.effect_type import EffectType
from armcal.effects.library import EffectSpec
from armcal.spec_parts.base import Number, SpecModel


class ThermalDrift(SpecModel):
    """Link lengths scaled by coefficient x (temperature - reference), or by drift rate x time."""

    type: Literal["thermal_drift"]
    source: Literal["temperature", "time"] = Field("temperature", description="the temperature column, or the time column t")
    coefficient: Number = Field(0.0, description="1/degC for temperature, 1/s for time")
    vary: bool = Field(True, description="identify the coefficient (else keep the value given)")
    reference_temperature: float = Field(20.0, description="degC")


class ThermalDriftType(EffectType):
    name = "thermal_drift"
    spec_model = ThermalDrift

    def fields(self, effect):
        return [("coefficient", "per_degC" if effect.source == "temperature" else "per_s")]

    def spec_keys(self, effect):
        return {"source": effect.source}

    def needs(self, effect):
        return {"temperature" if effect.source == "temperature" else "t"}

    def candidates(self, kinematics, data, harmonic_orders):
        if "temperature" in data.extras:
            return [EffectSpec(self, source="temperature")]
        return [EffectSpec(self, source="time")] if "t" in data.extras else []

    def length_change(self, effect, x, dof, value):
        change = x[dof + 1] - effect.reference_temperature if effect.source == "temperature" else x[dof]
        return value("coefficient") * change


THERMAL_DRIFT = ThermalDriftType()
