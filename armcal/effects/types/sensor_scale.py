"""sensor_scale: a scale error of an instrument's length readings (the speed of sound for the sonic digitizer).

The instruments that take it list it in their ``instrument_effects`` and propose it (``candidate_effects``).
"""

from __future__ import annotations

from typing import Literal

from armcal.effects.effect_type import EffectType
from armcal.spec_parts.base import Parameter, ScaleParam, SpecModel


class SensorScale(SpecModel):
    """Instrument scale error (speed of sound for the sonic digitizer)."""

    type: Literal["sensor_scale"]
    scale: ScaleParam = Parameter(value=0.0)


class SensorScaleType(EffectType):
    name = "sensor_scale"
    spec_model = SensorScale

    def fields(self, effect):
        return [("scale", "scale")]

    def reading(self, effect, channel, reading, value):
        return reading * (1 + value("scale")) if channel.kind == "length" else reading


SENSOR_SCALE = SensorScaleType()
