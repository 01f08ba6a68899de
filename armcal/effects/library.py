"""The effect vocabulary (docs/architecture.md) as internal descriptions with named parameters.

An effect is identified by its type and what it acts on (joint, driving joint,
harmonic order, microphone, pivot); its parameters are named ``<id>.<field>``, e.g.
``gear_harmonic.j2.h1.sin``, ``joint_coupling.j3.from2.coefficient``,
``joint_compliance.j2.mx3``. Spec effects (declared, or hidden in a simulation)
and the diagnosis' candidates are both turned into this form.

Compliance comes in two forms. ``masses``: one parameter, the compliance c, times
the gravity torque of declared (or default) lumped masses. ``moments``: the
gravity torque of the links beyond joint j is linear in their unknown first mass
moments, so the deflection is linear in the products "compliance x g x first
moment" (the elastostatic form); these products are the parameters, one per link
k >= j and axis c of frame F_k, named ``m<c><k>`` (an angle: the deflection that
moment alone causes when horizontal and square to the axis). A link's mass does
not appear on its own: in a revolute chain it regroups onto the first moments of
the links up to it (docs/effects.md). A prismatic joint has one product ``w``, the
deflection along its axis under the weight beyond it with the axis vertical.
Bending (``joint_bending``) has the same products, for the tilt of the links beyond
the joint about the axes square to it.

The description adds no field for these: a moments-form effect's products are the
keys of its ``values`` (every one present), a coupling's driving joint is its
``source``, the joint reading it follows ("q2"), as a thermal drift's is the
column it follows. So the record of every other effect (truth.json) is unchanged.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from armcal.kinematics.masses import LumpedMass
from armcal.kinematics.params import ParameterInfo

if TYPE_CHECKING:
    from armcal.effects.effect_type import EffectType

MOMENT_TERM = re.compile(r"^m([xyz])([1-9][0-9]*)$")  # a mass-moment product: axis of frame F_k, link k
AXIS_WEIGHT = "w"  # a prismatic joint's mass-moment product: deflection along the axis under the weight beyond it


def moment_terms(joint: int, dof: int, revolute: bool = True) -> tuple[str, ...]:
    """Every mass-moment product of joint ``joint``'s compliance (or bending): m<c><k> for links k = joint..dof,
    or a prismatic joint's ``w`` (compliance only)."""
    if not revolute:
        return (AXIS_WEIGHT,)
    return tuple(f"m{c}{k}" for k in range(joint, dof + 1) for c in "xyz")


def moment_link(term: str) -> tuple[int, int] | None:
    """(link, axis index) of a product m<c><k>; None for ``w`` or anything else."""
    match = MOMENT_TERM.match(term)
    return (int(match.group(2)), "xyz".index(match.group(1))) if match else None


def is_product(name: str) -> bool:
    return name == AXIS_WEIGHT or MOMENT_TERM.match(name) is not None


@dataclass(frozen=True)
class EffectSpec:
    """One effect: its type object (effects/effect_type.py), what it acts on, and its parameters' nominal values."""

    kind: EffectType
    joint: int | None = None  # 1-based
    order: int | None = None  # harmonic order (0 = a constant: absorbed by the joint offset)
    ratio: float = 1.0  # gear ratio for motor-side harmonics
    part: str | None = None  # the instrument's part it acts on (a microphone, a pivot), named by its type's part_key
    source: str = "temperature"  # the column it follows: thermal drift temperature or time; joint_coupling q<from>
    reference_temperature: float = 20.0
    masses: tuple[LumpedMass, ...] = ()
    values: dict[str, float] = field(default_factory=dict)  # nominal parameter values, 0 by default; see ``terms``
    free: bool = True  # False: every parameter held (a diagnosis candidate not yet accepted)
    held: frozenset[str] = frozenset()  # fields the spec holds at their value (vary: false)

    @property
    def type(self) -> str:
        """The type's name, as in a spec and in results.json."""
        return self.kind.name

    @property
    def source_joint(self) -> int | None:
        """joint_coupling: the driving joint (1-based), the spec's ``from``."""
        return self.kind.source_joint(self)

    @property
    def terms(self) -> tuple[str, ...]:
        """joint_compliance (form moments) and joint_bending: the mass-moment products, the keys of ``values``."""
        return tuple(k for k in self.values if is_product(k)) if self.kind.products else ()

    @property
    def form(self) -> str | None:
        """joint_compliance: "moments" when it has products, else "masses" (c x torque of lumped masses); None for
        the other types."""
        return self.kind.form(self)

    @property
    def followed_joint(self) -> int | None:
        """The joint whose angle a joint-side effect follows (a coupling: the driving joint), None for the others.
        Cross-validated along it (diagnose/loop.py), each fold holds out a contiguous range of that angle, so an
        effect must predict beyond the range it was fitted on, as a calibration is used: a function of one joint
        fitted over part of its period (a harmonic of order 3 over 96 deg of the UR10's shoulder) then fails, a
        physical one holds."""
        return self.source_joint if self.source_joint is not None else self.joint

    @property
    def id(self) -> str:
        parts = [self.type]
        if self.joint is not None:
            parts.append(f"j{self.joint}")
        if self.source_joint is not None:
            parts.append(f"from{self.source_joint}")
        if self.order is not None:
            parts.append(f"h{self.order}" + (f"r{self.ratio:g}" if self.ratio != 1.0 else ""))
        if self.part is not None:
            parts.append(self.part)
        return ".".join(parts)

    def fields(self) -> list[tuple[str, str]]:
        """(field, kind) of the effect's parameters."""
        return self.kind.fields(self)

    def parameters(self) -> list[ParameterInfo]:
        return [
            ParameterInfo(f"{self.id}.{f}", kind, self.values.get(f, 0.0), self.free and f not in self.held, None, None, role="effect")
            for f, kind in self.fields()
        ]


def product_fields(terms: tuple[str, ...]) -> list[tuple[str, str]]:
    """(field, kind) of mass-moment products: angles, a prismatic joint's w a length."""
    return [(t, "length" if t == AXIS_WEIGHT else "angle") for t in terms]


def with_products(kind: EffectType, joint: int, terms, values: dict | None = None, **rest) -> EffectSpec:
    """A moments-form compliance or a bending with the products ``terms`` (0 unless ``values`` gives them)."""
    return EffectSpec(kind, joint=joint, values={t: (values or {}).get(t, 0.0) for t in terms}, **rest)


def from_spec(effect) -> EffectSpec:
    """The internal form of a spec effect (values already in internal units); its spec model carries its type.

    Parameters are spec Parameters ({value, vary}; left out: free from 0) except
    joint_compliance's compliance and thermal_drift's coefficient, plain numbers
    with the effect's ``vary``. A compliance of form moments, and a bending, have
    the products the spec lists (the loader fills in those left out, from the
    robot's joints), each held when it says ``vary: false`` or the effect does.
    """
    kind = effect.effect_type
    products = kind.lists_products(effect)
    terms = _moment_products(effect) if products else ()
    if products and not terms:
        raise ValueError(f"{effect.type} of joint {effect.joint}: no products (load the spec with its robot to fill them in)")
    source = kind.source(effect)
    shape = EffectSpec(kind, source=source, values=dict.fromkeys(terms, 0.0))
    values, held = {}, set()
    for name, _ in shape.fields():
        parameter = (effect.model_extra or {}).get(name) if MOMENT_TERM.match(name) else getattr(effect, name)
        values[name] = parameter.value if hasattr(parameter, "value") else float(parameter)
        own = parameter.vary if hasattr(parameter, "vary") else True  # a plain number follows the effect's vary
        if not (own and getattr(effect, "vary", True)):
            held.add(name)
    masses = tuple(LumpedMass(m.link, m.mass, (m.x, m.y, m.z)) for m in getattr(effect, "masses", ()))
    return EffectSpec(
        kind=kind,
        joint=getattr(effect, "joint", None),
        order=getattr(effect, "order", None),
        ratio=getattr(effect, "ratio", 1.0),
        part=getattr(effect, kind.part_key) if kind.part_key else None,
        source=source,
        reference_temperature=getattr(effect, "reference_temperature", 20.0),
        masses=masses,
        values=values,
        held=frozenset(held),
    )


def _moment_products(effect) -> tuple[str, ...]:
    """The products a moments-form spec compliance or a bending lists: m<c><k> by link and axis, then w."""
    listed = [key for key in (effect.model_extra or {}) if MOMENT_TERM.match(key)]
    ordered = sorted(listed, key=moment_link)
    return tuple(ordered) + ((AXIS_WEIGHT,) if getattr(effect, "w", None) is not None else ())


def needs(effects: list[EffectSpec]) -> set[str]:
    """Extra data columns the effects need: dir, temperature, t."""
    out = set()
    for effect in effects:
        out |= effect.kind.needs(effect)
    return out


def to_spec_dict(effect: EffectSpec, values: dict[str, float]) -> dict:
    """A spec ``effects:`` entry for calibrated.yaml (values in internal units; the caller converts)."""
    out: dict = {"type": effect.type}
    for key in ("joint", "order"):
        if getattr(effect, key) is not None:
            out[key] = getattr(effect, key)
    if effect.part is not None:
        out[effect.kind.part_key] = effect.part
    out.update(effect.kind.spec_keys(effect))
    out.update(values)
    return out
