"""The spec's effect entries (``effects``, ``simulate.effects``): one model per effect type, chosen by ``type``.

The types are armcal/devices/registry.py's vocabulary: each type's module holds its entry model
(``EffectType.spec_model``); docs/effects.md is the user's reference. An entry is checked against the vocabulary at
the time, so a plug-in type registered after this module is imported is accepted too; the JSON Schema shows the
types known at import.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated, Any, Union

from pydantic import Field, PlainValidator, TypeAdapter, ValidationInfo

from armcal.devices.registry import vocabulary


def _union(types: tuple) -> Any:
    return Annotated[Union[tuple(t.spec_model for t in types)], Field(discriminator="type")]


@lru_cache(maxsize=None)
def _adapter(types: tuple) -> TypeAdapter:
    return TypeAdapter(_union(types))


def _entry(value: Any, info: ValidationInfo) -> Any:
    return _adapter(tuple(vocabulary().values())).validate_python(value, context=info.context)


EFFECT_NAMES = tuple(vocabulary())
Effect = Annotated[Any, PlainValidator(_entry, json_schema_input_type=_union(tuple(vocabulary().values())))]
