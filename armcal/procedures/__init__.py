"""Pose planning with the nominal model: circle-point sweeps, shells, pose lists, evaluation tasks."""

from pathlib import Path

from armcal.devices.base import DeviceModel
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures.circle_point import plan_circle_point
from armcal.procedures.plan import Plan
from armcal.procedures.poses import plan_poses
from armcal.procedures.shells import plan_shells
from armcal.spec.document import Spec
from armcal.spec.procedure import CirclePoint, Shells


def plan(procedure, kinematics: KinematicModel, device: DeviceModel, spec: Spec, spec_dir: Path) -> Plan:
    """The samples a procedure of ``spec`` (its ``procedure`` or ``validation``) measures."""
    if isinstance(procedure, CirclePoint):
        return plan_circle_point(procedure, kinematics, device)
    if isinstance(procedure, Shells):
        return plan_shells(procedure, kinematics, device, angle_unit=spec.robot.units.angle)
    return plan_poses(procedure, kinematics, device, spec, spec_dir)


__all__ = ["Plan", "plan"]
