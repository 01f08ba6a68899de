"""Measurement models of the seeds' instruments: sonic digitizer, ball-bar, theodolite, tracker."""

from armcal.devices.ballbar import BallBarModel
from armcal.devices.base import Channel, DeviceModel, Key
from armcal.devices.sonic import SonicModel
from armcal.devices.theodolite import TheodoliteModel
from armcal.devices.tracker import TrackerModel
from armcal.spec.model import Spec
from armcal.spec.procedure import CirclePoint


def device_model(spec: Spec, mode: str = "ranges") -> DeviceModel:
    """The measurement model of a spec's device (sonic: ``mode`` ranges or points)."""
    device = spec.device
    if device.type == "sonic_digitizer":
        averaging = spec.procedure.averaging if isinstance(spec.procedure, CirclePoint) else 1
        return SonicModel(device, averaging=averaging, mode=mode)
    if device.type == "ballbar":
        return BallBarModel(device)
    if device.type == "theodolite":
        return TheodoliteModel(device)
    return TrackerModel(device)


__all__ = ["Channel", "DeviceModel", "Key", "device_model"]
