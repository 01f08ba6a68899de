"""Spec language: the whole calibration spec as pydantic models, its YAML loading, checks and JSON Schema.

The parts the instruments build their sections on are armcal/spec_parts/; the ``device`` union is the
instruments' (armcal/devices/registry.py).
"""

from armcal.spec.document import Spec
from armcal.spec.loader import LoadedSpec, load_spec

__all__ = ["LoadedSpec", "Spec", "load_spec"]
