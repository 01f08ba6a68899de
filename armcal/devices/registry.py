"""The registry of instruments: one entry per measuring method, its measurement model (which names its spec section);
and the whole effect vocabulary, the effects' registry with the instruments' own effect types.

Nothing outside armcal/devices/ names an instrument: the spec's ``device`` union, the
data files' columns, the campaign's simulation, the diagnosis' instrument-side
candidates and the certificate's description all ask the entry of ``device.type``.
"""

from __future__ import annotations

from armcal.devices.ballbar import BallBarModel
from armcal.devices.base import DeviceModel
from armcal.devices.plane_contact import PlaneContactModel
from armcal.devices.sonic import SonicModel
from armcal.devices.sphere_socket import SphereSocketModel
from armcal.devices.theodolite import TheodoliteModel
from armcal.devices.tracker import TrackerModel
from armcal.effects.effect_type import EffectType
from armcal.effects.registry import effect_types

INSTRUMENTS: dict[str, type[DeviceModel]] = {model.type: model for model in (SonicModel, BallBarModel, TheodoliteModel, TrackerModel, SphereSocketModel, PlaneContactModel)}


def instruments_where(test) -> list[str]:
    """The registered device types whose spec section passes ``test`` (e.g. takes a procedure), in registry order."""
    return [name for name, model in INSTRUMENTS.items() if test(model.section)]


def accepting(effect_name: str) -> list[str]:
    """The instruments an instrument-side effect acts on (none: an effect on the robot's side)."""
    return instruments_where(lambda section: effect_name in {t.name for t in section.instrument_effects})


def vocabulary() -> dict[str, EffectType]:
    """Every effect type by name: the effects' registry (plug-ins included), then the instruments' own, in registry order."""
    out = {t.name: t for t in effect_types()}
    for model in INSTRUMENTS.values():
        out.update({t.name: t for t in model.section.instrument_effects if t.name not in out})
    return out
