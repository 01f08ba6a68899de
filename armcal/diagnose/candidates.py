"""The effects the diagnosis may propose: every candidate the data could show and the model lacks.

Each effect type proposes its own (EffectType.candidates: compliance and bending chosen with the poses in mind,
couplings between joints a mechanism links; their modules say how), the instrument its instrument-side ones. A type
marked opt_in (bending) is tried only when ``diagnose.candidates`` names it.
"""

from __future__ import annotations

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.effects.library import EffectSpec
from armcal.effects.registry import effect_types
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.sections import Diagnose


def candidates(
    kinematics: KinematicModel, device: DeviceModel, data: Measurements, in_model: list[EffectSpec], settings: Diagnose
) -> list[EffectSpec]:
    """Candidate effects for ``data``, leaving out those in the model and those the settings exclude: a joint's in
    the order of the effect types, joint by joint, then those of no joint, then the instrument's."""
    allowed = set(settings.candidates) if settings.candidates else None
    tried = [t for t in effect_types() if (not t.opt_in if allowed is None else t.name in allowed)]
    proposed = [c for t in tried for c in t.candidates(kinematics, data, settings.harmonic_orders)]
    out = sorted(proposed, key=lambda c: kinematics.dof + 1 if c.joint is None else c.joint)
    out += [c for c in device.candidate_effects({e.name for e in device.parameters.entries if e.free}) if allowed is None or c.type in allowed]
    taken = {e.id for e in in_model}
    return [c for c in out if c.id not in taken]
