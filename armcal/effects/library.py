"""The effect vocabulary (ARCHITECTURE.md) as internal descriptions with named parameters.

An effect is identified by its type and what it acts on (joint, harmonic order,
microphone, pivot); its parameters are named ``<id>.<field>``, e.g.
``gear_harmonic.j2.h1.sin``. Spec effects (declared, or hidden in a simulation)
and the diagnosis' candidates are both turned into this form.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from armcal.kinematics.params import ParameterInfo

JOINT_SIDE = ("encoder_scale", "gear_harmonic", "joint_compliance", "backlash")
DEVICE_SIDE = ("sensor_scale", "range_bias", "ballbar_length", "pivot_offset")


@dataclass(frozen=True)
class LumpedMass:
    link: int
    mass: float  # kg
    centre: tuple[float, float, float]  # mm, in the link frame


@dataclass(frozen=True)
class EffectSpec:
    """One effect: what it is, what it acts on, and its parameters' nominal values."""

    type: str
    joint: int | None = None  # 1-based
    order: int | None = None  # harmonic order (0 = a constant: absorbed by the joint offset)
    ratio: float = 1.0  # gear ratio for motor-side harmonics
    microphone: str | None = None
    pivot: str | None = None
    source: str = "temperature"  # thermal drift: temperature or time
    reference_temperature: float = 20.0
    masses: tuple[LumpedMass, ...] = ()
    values: dict[str, float] = field(default_factory=dict)  # nominal parameter values, 0 by default
    free: bool = True  # False: every parameter held (a diagnosis candidate not yet accepted)
    held: frozenset[str] = frozenset()  # fields the spec holds at their value (vary: false)

    @property
    def id(self) -> str:
        parts = [self.type]
        if self.joint is not None:
            parts.append(f"j{self.joint}")
        if self.order is not None:
            parts.append(f"h{self.order}" + (f"r{self.ratio:g}" if self.ratio != 1.0 else ""))
        if self.microphone is not None:
            parts.append(self.microphone)
        if self.pivot is not None:
            parts.append(self.pivot)
        return ".".join(parts)

    def fields(self) -> list[tuple[str, str]]:
        """(field, kind) of the effect's parameters."""
        return {
            "encoder_scale": [("scale", "scale")],
            "gear_harmonic": [("sin", "angle"), ("cos", "angle")],
            "joint_compliance": [("compliance", "compliance")],
            "backlash": [("half_width", "angle")],
            "thermal_drift": [("coefficient", "per_degC" if self.source == "temperature" else "per_s")],
            "sensor_scale": [("scale", "scale")],
            "range_bias": [("bias", "length")],
            "ballbar_length": [("offset", "length")],
            "pivot_offset": [("x", "length"), ("y", "length"), ("z", "length")],
        }[self.type]

    def parameters(self) -> list[ParameterInfo]:
        return [
            ParameterInfo(f"{self.id}.{f}", kind, self.values.get(f, 0.0), self.free and f not in self.held, None, None, role="effect")
            for f, kind in self.fields()
        ]


def from_spec(effect) -> EffectSpec:
    """The internal form of a spec effect (values already in internal units).

    Parameters are spec Parameters ({value, vary}; left out: free from 0) except
    joint_compliance's compliance and thermal_drift's coefficient, plain numbers
    with the effect's ``vary``.
    """
    shape = EffectSpec(effect.type, source=getattr(effect, "source", "temperature"))
    values, held = {}, set()
    for name, _ in shape.fields():
        parameter = getattr(effect, name)
        values[name] = parameter.value if hasattr(parameter, "value") else float(parameter)
        if not (parameter.vary if hasattr(parameter, "vary") else effect.vary):
            held.add(name)
    masses = tuple(LumpedMass(m.link, m.mass, (m.x, m.y, m.z)) for m in getattr(effect, "masses", ()))
    return EffectSpec(
        type=effect.type,
        joint=getattr(effect, "joint", None),
        order=getattr(effect, "order", None),
        ratio=getattr(effect, "ratio", 1.0),
        microphone=getattr(effect, "microphone", None),
        pivot=getattr(effect, "pivot", None),
        source=shape.source,
        reference_temperature=getattr(effect, "reference_temperature", 20.0),
        masses=masses,
        values=values,
        held=frozenset(held),
    )


def needs(effects: list[EffectSpec]) -> set[str]:
    """Extra data columns the effects need: dir, temperature, t."""
    out = set()
    for effect in effects:
        if effect.type == "backlash":
            out.add("dir")
        if effect.type == "thermal_drift":
            out.add("temperature" if effect.source == "temperature" else "t")
    return out


def to_spec_dict(effect: EffectSpec, values: dict[str, float]) -> dict:
    """A spec ``effects:`` entry for calibrated.yaml (values in internal units; the caller converts)."""
    out: dict = {"type": effect.type}
    for key in ("joint", "order", "microphone", "pivot"):
        if getattr(effect, key) is not None:
            out[key] = getattr(effect, key)
    if effect.type == "gear_harmonic" and effect.ratio != 1.0:
        out["ratio"] = effect.ratio
    if effect.type == "thermal_drift":
        out["source"] = effect.source
    out.update(values)
    return out
