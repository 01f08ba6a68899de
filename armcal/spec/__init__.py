"""Spec language: pydantic models of a calibration spec and their YAML loading."""

from armcal.spec.loader import LoadedSpec, load_spec
from armcal.spec.model import Spec

__all__ = ["LoadedSpec", "Spec", "load_spec"]
