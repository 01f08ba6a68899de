"""Spec language: pydantic models of a calibration spec and their YAML loading.

``load_spec``, ``LoadedSpec`` and ``Spec`` load on first use: the device section is the
instruments' (armcal/devices/), whose modules import the spec's building blocks from here.
"""

from __future__ import annotations

import importlib

_EXPORTS = {"LoadedSpec": "armcal.spec.loader", "load_spec": "armcal.spec.loader", "Spec": "armcal.spec.document"}
__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'armcal.spec' has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
