"""What an effect type is: the interface each effect's module fills in (docs/architecture.md, "A new effect").

One object per type (a subclass of ``EffectType``, one instance) holds the spec model of its entries, its
parameters, its terms in the measurement model h(q) = instrument(chain(q)) (effects/measurement.py asks each
effect's type for them), its diagnosis candidates, the data columns it needs, its extra keys in calibrated.yaml and
whether ``armcal compensate`` inverts it. A term a type does not have is the neutral default below. Effects are
described by ``EffectSpec`` (effects/library.py), which carries its type object.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field

from armcal.spec_parts.base import SpecModel

if TYPE_CHECKING:
    from armcal.effects.library import EffectSpec


class EffectType:
    """One effect type. ``value(field)`` in the terms below is the symbol of the effect's parameter ``<id>.<field>``."""

    name: ClassVar[str]  # the spec's ``type`` and results.json's
    spec_model: ClassVar[type[SpecModel]]  # a spec ``effects:`` entry of this type
    compensated: ClassVar[bool] = False  # compensate inverts it: its joint deviation is a function of the joints alone
    opt_in: ClassVar[bool] = False  # the diagnosis tries it only when diagnose.candidates names it
    products: ClassVar[bool] = False  # its parameters may be mass-moment products m<c><k>, the keys of its values
    tilts: ClassVar[bool] = False  # it tilts the links beyond its joint (``tilt``)
    part_key: ClassVar[str | None] = None  # the spec key naming the instrument's part it acts on (EffectSpec.part)

    def __init__(self) -> None:
        self.spec_model.effect_type = self

    def __repr__(self) -> str:
        return f"<effect type {self.name}>"

    def fields(self, effect: EffectSpec) -> list[tuple[str, str]]:
        """(field, kind) of the effect's parameters."""
        raise NotImplementedError

    def lists_products(self, entry) -> bool:
        """Whether a spec entry's parameters are the mass-moment products it lists."""
        return self.products

    def form(self, effect: EffectSpec) -> str | None:
        """joint_compliance's form (EffectSpec.form); None for the other types."""
        return None

    def source(self, entry) -> str:
        """The column a spec entry follows (EffectSpec.source)."""
        return getattr(entry, "source", "temperature")

    def source_joint(self, effect: EffectSpec) -> int | None:
        """The driving joint (1-based) of an effect whose joint follows another's reading."""
        return None

    def spec_keys(self, effect: EffectSpec) -> dict:
        """Its keys in a calibrated.yaml ``effects:`` entry besides type, joint, order, its part and values."""
        return {}

    def needs(self, effect: EffectSpec) -> set[str]:
        """Extra data columns it needs: dir, temperature, t."""
        return set()

    def candidates(self, kinematics, data, harmonic_orders: int) -> list[EffectSpec]:
        """The effects of this type the diagnosis may propose for ``data`` (Measurements) and the compiled chain."""
        return []

    def joint_deviation(self, effect: EffectSpec, chain, value):
        """Its deviation of joint ``effect.joint`` at ``chain`` (effects/measurement.py's ChainState), else None."""
        return None

    def tilt(self, effect: EffectSpec, frames, value):
        """A type that ``tilts``: the rotation vector tilting the links beyond its joint about o_(joint-1), from the
        frames F_0..F_n."""
        return None

    def length_change(self, effect: EffectSpec, x, dof: int, value):
        """Its relative change of every robot length, from the extras x [dir_1..dir_n, t, temperature], else None."""
        return None

    def device_shift(self, effect: EffectSpec, parameters, value) -> dict:
        """{index in the instrument's parameters: the shift it adds there}."""
        return {}

    def reading(self, effect: EffectSpec, channel, reading, value):
        """One reading of ``channel`` (its name and kind) with this effect."""
        return reading


class JointEffect(SpecModel):
    """An effect acting on one joint (1-based)."""

    joint: int = Field(ge=1, description="joint number, 1-based")
