"""The ``device`` section: the measuring instrument, one of the registry's, discriminated on ``type``.

Each instrument's section is declared in its module under armcal/devices/; what they
share (noise sigmas or auto, noise groups, the instrument's identity) in spec_parts/instrument.py.
"""

from __future__ import annotations

from typing import Annotated, Union

from pydantic import Field

from armcal.devices.registry import INSTRUMENTS

Device = Annotated[Union[tuple(model.section for model in INSTRUMENTS.values())], Field(discriminator="type")]
DEVICE_TYPES = ", ".join(INSTRUMENTS)  # the device.type values, for descriptions
