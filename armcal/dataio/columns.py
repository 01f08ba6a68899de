"""The CSV columns of a spec's data files (contract in ARCHITECTURE.md) and their units.

Common: ``sample``, ``q1..qN`` (spec angle unit for revolute joints, length unit
for prismatic), optional ``t`` (s), ``temperature`` (degC), ``dir1..dirN`` (+1/-1).
Per device:
  ballbar     pivot, sphere, length [, extension]
  sonic       target and either s_A, s_B, s_C[, s_D] (slant ranges, with optional
              calibration-rod ranges rod_<mic>_1, rod_<mic>_2) or x, y, z (triangulated)
  theodolite  station, target, azimuth, elevation
  tracker     target, x, y, z [, rx, ry, rz]
"""

from __future__ import annotations

from dataclasses import dataclass

from armcal.spec.model import Spec
from armcal.spec.robot import joint_kind


@dataclass(frozen=True)
class Layout:
    """Which columns a data file of a spec may have, and the kind of each."""

    key_columns: tuple[str, ...]
    required: dict[str, str]  # column -> kind (length, angle, ...)
    optional: dict[str, str]
    sonic_mode: str | None = None

    @property
    def known(self) -> dict[str, str]:
        return {**self.required, **self.optional}


def _common(spec: Spec) -> tuple[dict[str, str], dict[str, str]]:
    n = spec.robot.dof
    joints = {f"q{i + 1}": joint_kind(j.type) for i, j in enumerate(spec.robot.joints)}
    optional = {"sample": "text", "t": "time", "temperature": "temperature"}
    optional.update({f"dir{i}": "direction" for i in range(1, n + 1)})
    return joints, optional


def layout(spec: Spec, header: list[str]) -> Layout:
    """The layout of a data file with this header (the sonic digitizer's mode is read from it)."""
    required, optional = _common(spec)
    device = spec.device
    if device.type == "ballbar":
        return Layout(("pivot", "sphere"), {**required, "pivot": "text", "sphere": "text", "length": "length"}, {**optional, "extension": "text"})
    if device.type == "theodolite":
        return Layout(("station", "target"), {**required, "station": "text", "target": "text", "azimuth": "angle", "elevation": "angle"}, optional)
    if device.type == "tracker":
        readings = {c: "length" for c in "xyz"}
        if device.orientation:
            readings.update({c: "angle" for c in ("rx", "ry", "rz")})
        return Layout(("target",), {**required, "target": "text", **readings}, optional)
    if "x" in header and not any(h.startswith("s_") for h in header):
        return Layout(("target",), {**required, "target": "text", **{c: "length" for c in "xyz"}}, optional, "points")
    ranges = {f"s_{m}": "length" for m in device.microphones if m in ("A", "B", "C")}
    extra = {f"s_{m}": "length" for m in device.microphones if m not in ranges}
    rods = {f"rod_{rod.microphone}_{i}": "length" for rod in device.calibration_rods for i in (1, 2)}
    return Layout(("target",), {**required, "target": "text", **ranges}, {**optional, **extra, **rods}, "ranges")
