"""The CSV columns of a spec's data files (contract in docs/architecture.md) and their units.

Common: ``sample``, ``q1..qN`` (spec angle unit for revolute joints, length unit
for prismatic), optional ``t`` (s), ``temperature`` (degC), ``dir1..dirN`` (+1/-1).
The instrument adds its key columns and readings (DeviceModel.key_columns,
reading_columns; the contract lists each instrument's).
"""

from __future__ import annotations

from dataclasses import dataclass

from armcal.devices import DeviceModel
from armcal.spec.document import Spec
from armcal.kinematics.params import joint_kind


@dataclass(frozen=True)
class Layout:
    """Which columns a data file of a spec may have, and the kind of each."""

    key_columns: tuple[str, ...]  # the instrument's text columns that make a sample's key
    required: dict[str, str]  # column -> kind (length, angle, ...)
    optional: dict[str, str]
    optional_keys: tuple[str, ...] = ()  # key columns a file may leave out or empty (None in the key)

    @property
    def known(self) -> dict[str, str]:
        return {**self.required, **self.optional}


def joint_columns(spec: Spec) -> dict[str, str]:
    """q1..qN -> angle (revolute) or length (prismatic)."""
    return {f"q{i + 1}": joint_kind(j.type) for i, j in enumerate(spec.robot.joints)}


def layout(spec: Spec, header: list[str], device: DeviceModel) -> Layout:
    """The layout of a data file with this header, for the spec's instrument ``device`` (an instrument that offers a
    choice of readings tells it from the header)."""
    joints = joint_columns(spec)
    optional = {"sample": "text", "t": "time", "temperature": "temperature", **{f"dir{i}": "direction" for i in range(1, spec.robot.dof + 1)}}
    keys = {c: "text" for c in device.key_columns}
    readings, extra = device.reading_columns(header)
    optional_keys = {c: "text" for c in device.optional_key_columns}
    return Layout(device.key_columns, {**joints, **keys, **readings}, {**optional, **optional_keys, **extra}, device.optional_key_columns)
