"""Measuring instruments, one module each (registry.py lists them), behind DeviceModel."""

from __future__ import annotations

from armcal.devices.base import Channel, DeviceModel, Key
from armcal.devices.registry import INSTRUMENTS


def device_model(spec, mode: str | None = None) -> DeviceModel:
    """The measurement model of a spec's device (``spec``: armcal/spec/'s Spec, which the instruments stand below;
    ``mode``: which readings it fits where it offers a choice, None: as its section says)."""
    return INSTRUMENTS[spec.device.type].from_spec(spec, mode)


def readings_mode(spec, header: list[str], requested: str | None = None) -> str | None:
    """The readings a data file with this header holds, where the spec's instrument offers a choice."""
    return INSTRUMENTS[spec.device.type].readings_mode(header, requested)


__all__ = ["Channel", "DeviceModel", "Key", "device_model", "readings_mode"]
