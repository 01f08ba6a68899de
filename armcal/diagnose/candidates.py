"""The effects the diagnosis may propose: every type x joint x order the data could show and the model lacks."""

from __future__ import annotations

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.effects.library import EffectSpec
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.sections import Diagnose


def _device_free(device: DeviceModel, prefix: str) -> bool:
    return any(e.free for e in device.parameters.entries if e.name.startswith(prefix))


def candidates(
    kinematics: KinematicModel, device: DeviceModel, data: Measurements, in_model: list[EffectSpec], settings: Diagnose
) -> list[EffectSpec]:
    """Candidate effects for ``data``, leaving out those in the model and those the settings exclude."""
    out: list[EffectSpec] = []
    free = {e.name for e in kinematics.parameters.entries if e.free}
    for joint, name in enumerate(kinematics.joint_names, start=1):
        if f"{name}.k" not in free:  # six_parameter's free encoder scale is this effect already
            out.append(EffectSpec("encoder_scale", joint=joint))
        out += [EffectSpec("gear_harmonic", joint=joint, order=h) for h in range(1, settings.harmonic_orders + 1)]
        out.append(EffectSpec("joint_compliance", joint=joint))
        if "dir" in data.extras:
            out.append(EffectSpec("backlash", joint=joint))
    if "temperature" in data.extras:
        out.append(EffectSpec("thermal_drift", source="temperature"))
    elif "t" in data.extras:
        out.append(EffectSpec("thermal_drift", source="time"))
    lengths = [c for key in dict.fromkeys(data.keys) for c in device.channels(key) if c.kind == "length"]
    if lengths and device.type in ("sonic_digitizer", "tracker") and not _device_free(device, f"{device.type.split('_')[0]}.scale"):
        out.append(EffectSpec("sensor_scale"))
    if device.type == "sonic_digitizer" and getattr(device, "mode", "") == "ranges":
        out += [EffectSpec("range_bias", microphone=m) for m in device.microphones]
    if device.type == "ballbar":
        if not _device_free(device, "bar.length"):
            out.append(EffectSpec("ballbar_length"))
        out += [EffectSpec("pivot_offset", pivot=p) for p in device.spec.pivots if not _device_free(device, f"pivot.{p}.")]
    taken = {e.id for e in in_model}
    allowed = set(settings.candidates) if settings.candidates else None
    return [c for c in out if c.id not in taken and (allowed is None or c.type in allowed)]
