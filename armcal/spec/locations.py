"""Where a parameter of the calibration model lives in the spec's YAML (calibrated.yaml writes there; the likely
causes of a failed noise check name it)."""

from __future__ import annotations

from armcal.effects.library import from_spec
from armcal.spec.document import Spec


def yaml_path(name: str, spec: Spec) -> list:
    """Where a parameter lives in the spec's YAML."""
    head, _, field = name.rpartition(".")
    declared = [from_spec(e).id for e in spec.effects]
    if head in declared:
        return ["effects", declared.index(head), field]
    robot = spec.robot
    if head in ("base", "tool"):
        return ["robot", head, field]
    if head in robot.joint_names():
        return ["robot", "joints", robot.joint_names().index(head), field]
    if head.startswith("L") and head[1:].isdigit():
        return ["robot", "links", int(head[1:]) - 1, field]
    if head in robot.targets:
        return ["robot", "targets", head, field]
    return spec.device.parameter_location(name)
