"""Measuring instruments, one module each (registry.py lists them), behind DeviceModel."""

from __future__ import annotations

from typing import TYPE_CHECKING

from armcal.devices.base import Channel, DeviceModel, Key
from armcal.devices.registry import INSTRUMENTS

if TYPE_CHECKING:
    from armcal.spec.document import Spec


def device_model(spec: Spec, mode: str = "ranges") -> DeviceModel:
    """The measurement model of a spec's device (``mode``: which readings it fits where it offers a choice)."""
    return INSTRUMENTS[spec.device.type].from_spec(spec, mode)


def readings_mode(spec: Spec, header: list[str], requested: str) -> str:
    """The readings a data file with this header holds, where the spec's instrument offers a choice."""
    return INSTRUMENTS[spec.device.type].readings_mode(header, requested)


__all__ = ["Channel", "DeviceModel", "Key", "device_model", "readings_mode"]
