"""Parameter sweeps of a Monte-Carlo study: the spec with one input changed (Stone 7.4.1, 7.4.3-7.4.5).

A sweep is written ``name=v1,v2,...`` with values in the spec's units (or with a
unit, "30 cm"). Each variable is known with the trend Stone found for the
standard deviations of the grid indices, so a study can say whether it holds:
``expected_slope`` is d log(std) / d log(value) for the controller named.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ValidationError

from armcal.support import units
from armcal.support.errors import UserError
from armcal.kinematics.compiler import compile_robot
from armcal.spec_parts.base import Parameter
from armcal.spec.document import Spec
from armcal.spec.procedure import CirclePoint
from armcal.spec.sections import Simulate


@dataclass(frozen=True)
class Variable:
    kind: str  # unit kind of the values: length, angle, scale, count
    controller: str  # the controller whose index spread the variable drives
    expected_slope: float  # Stone's trend, d log(std) / d log(value)
    source: str
    meaning: str


VARIABLES = {
    "noise_factor": Variable("scale", "calibrated", 1.0, "Stone 7.4.3", "instrument noise sigma times k"),
    "points_per_joint": Variable("count", "calibrated", -0.5, "Stone 7.4.4", "points per circle N_i"),
    "target_radius": Variable("length", "calibrated", -2.0, "Stone 7.4.5", "every target's radius R from its joint axis"),
    "sigma_e": Variable("angle", "design", 1.0, "Stone 7.4.1", "encoder calibration error sigma"),
}


MAX_VALUES = 20  # values of one sweep: a trend needs a few, and each is a whole study of --runs robots
SWEPT_FIELDS = {"noise_factor": "simulate.noise_factor", "sigma_e": "simulate.sigma_e",
                "points_per_joint": "procedure.points_per_joint", "target_radius": "robot.targets"}
INTERNAL_UNITS = {"units": {"length": "mm", "angle": "rad", "scale": "1"}}  # a variant's values are internal


@dataclass(frozen=True)
class Sweep:
    variable: str
    values: tuple[float, ...]  # internal units (mm, rad, 1)
    shown: tuple[float, ...]  # as written, in the spec's units


def parse_sweep(text: str, spec: Spec) -> Sweep:
    """``name=v1,v2,...`` -> a Sweep, values converted from the spec's units; a user error names what is wrong."""
    name, _, raw = text.partition("=")
    name = name.strip()
    if name not in VARIABLES:
        raise UserError(f"--sweep {text!r}: unknown variable {name!r}; choose one of {', '.join(VARIABLES)}")
    items = [item.strip() for item in raw.split(",") if item.strip()]
    if len(items) < 2:
        raise UserError(f"--sweep {text!r}: give at least two values, e.g. {name}=1,2,5")
    if len(items) > MAX_VALUES:
        raise UserError(f"--sweep {name}: {len(items)} values, at most {MAX_VALUES} (a trend needs a few; each value is a "
                        "whole study of --runs robots)")
    kind = VARIABLES[name].kind
    unit = spec.robot.units.of(kind)
    values, shown = [], []
    for item in items:
        try:
            value = float(item) if kind == "count" else units.to_internal(item, kind, unit)
        except ValueError as exc:
            raise UserError(f"--sweep {text!r}: {item!r} is not a valid {kind} ({exc})") from None
        if not (math.isfinite(value) and value > 0) or (kind == "count" and (value != int(value) or value < 3)):
            wanted = "whole number of at least 3 (a circle needs 3 points)" if kind == "count" else "finite number"
            raise UserError(f"--sweep {text!r}: {item!r} must be a positive {wanted}")
        if any(math.isclose(value, earlier) for earlier in values):
            raise UserError(f"--sweep {text!r}: {item!r} repeats a value; a trend needs distinct values")
        values.append(value)
        shown.append(value if kind in ("count", "scale") else units.from_internal(value, kind, unit))
    return Sweep(name, tuple(values), tuple(shown))


def variant(spec: Spec, variable: str, value: float) -> Spec:
    """The spec with ``variable`` set to ``value`` (internal units), validated as a spec is (its bounds, e.g.
    points_per_joint at most 200000, and its cross-checks): a user error names the value and the problem."""
    try:
        return _variant(spec, variable, value)
    except ValidationError as exc:
        shown = f"{value:.12g}" if VARIABLES[variable].kind in ("count", "scale") else "one of its values"
        raise UserError(f"--sweep {variable}: {shown} makes no valid spec ({SWEPT_FIELDS[variable]}: "
                        f"{exc.errors()[0]['msg']})") from None


def _variant(spec: Spec, variable: str, value: float) -> Spec:
    simulate = spec.simulate or Simulate()
    if variable in ("noise_factor", "sigma_e"):
        return _validated(spec, simulate=_validated(simulate, **{variable: value}))
    procedure = spec.procedure
    if not isinstance(procedure, CirclePoint):
        raise UserError(f"the {variable} sweep varies Stone's circle-point procedure; this spec's procedure is {procedure.type}")
    if variable == "points_per_joint":
        return _validated(spec, procedure=_validated(procedure, points_per_joint=int(value)))
    return _validated(spec, robot=_targets_at_radius(spec, procedure, value))


def _validated(model: BaseModel, **update) -> BaseModel:
    """``model`` with ``update`` applied and validated again (model_copy would skip every check); values in
    internal units, the unchanged parts as they are."""
    return type(model).model_validate({**dict(model), **update}, context=INTERNAL_UNITS)


def _targets_at_radius(spec: Spec, procedure: CirclePoint, radius: float):
    """The robot with each swept target moved, along its radius, to ``radius`` from its joint's axis.

    Joint i turns about the z axis of frame F_{i-1} (kinematics/compiler.py); the
    target keeps its height along the axis and its direction from it (at the
    signature configuration), only its distance R_i changes (Stone 7.4.5).
    """
    robot = spec.robot
    kinematics = compile_robot(robot.chain())
    frames = kinematics.link_frames(np.asarray(procedure.signature))
    targets = dict(robot.targets)
    for joint, name in enumerate(procedure.targets, start=1):
        if kinematics.joint_types[joint - 1] != "revolute":
            continue
        target = targets[name]
        link = frames[target.link]
        point = link @ np.array([target.x.value, target.y.value, target.z.value, 1.0])
        axis_origin, axis = frames[joint - 1][:3, 3], frames[joint - 1][:3, 2]
        offset = point[:3] - axis_origin
        radial = offset - (offset @ axis) * axis
        if np.linalg.norm(radial) < 1e-6:
            raise UserError(f"target {name} lies on joint {joint}'s axis; the target_radius sweep cannot move it outwards")
        moved = point[:3] + (radius / np.linalg.norm(radial) - 1.0) * radial
        local = np.linalg.solve(link, np.r_[moved, 1.0])[:3]
        coordinates = {c: _with_value(getattr(target, c), v) for c, v in zip("xyz", local)}
        targets[name] = _validated(target, **coordinates)
    return _validated(robot, targets=targets)


def _with_value(parameter: Parameter, value: float) -> Parameter:
    return _validated(parameter, value=float(value))
