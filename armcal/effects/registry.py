"""The registry of effect types on the robot's side or on any length reading, in the order of their parameters and
of the spec's effect union; the instruments' own effect types are in their modules (armcal/devices/registry.py
composes the whole vocabulary). A plug-in effect type, defined outside armcal, is added with ``register``."""

from __future__ import annotations

from armcal.effects.effect_type import EffectType
from armcal.effects.types.backlash import BACKLASH
from armcal.effects.types.encoder_scale import ENCODER_SCALE
from armcal.effects.types.gear_harmonic import GEAR_HARMONIC
from armcal.effects.types.joint_bending import JOINT_BENDING
from armcal.effects.types.joint_compliance import JOINT_COMPLIANCE
from armcal.effects.types.joint_coupling import JOINT_COUPLING
from armcal.effects.types.sensor_scale import SENSOR_SCALE
from armcal.effects.types.thermal_drift import THERMAL_DRIFT

SHIPPED: tuple[EffectType, ...] = (ENCODER_SCALE, GEAR_HARMONIC, JOINT_COMPLIANCE, JOINT_COUPLING, JOINT_BENDING, BACKLASH, THERMAL_DRIFT, SENSOR_SCALE)
_plug_ins: dict[str, EffectType] = {}


def register(effect_type: EffectType) -> None:
    """Add a plug-in effect type: the spec's ``effects:`` and ``simulate.effects`` accept it from then on."""
    if effect_type.name in {t.name for t in effect_types()}:
        raise ValueError(f"an effect type named {effect_type.name} is registered already")
    _plug_ins[effect_type.name] = effect_type


def unregister(effect_type: EffectType) -> None:
    """Remove a plug-in effect type ``register`` added."""
    del _plug_ins[effect_type.name]


def effect_types() -> tuple[EffectType, ...]:
    """The shipped types, then the plug-ins in the order they were registered."""
    return (*SHIPPED, *_plug_ins.values())
