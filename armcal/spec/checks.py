"""Cross-reference checks that a single field cannot make on its own.

Each check yields (location, message) where location is the path of the field
in the spec, so the loader can name file, line and column.
"""

from __future__ import annotations

from collections.abc import Iterator

from armcal.devices.registry import accepting, instruments_where
from armcal.support.errors import either, shown_value, with_article
from armcal.spec.document import Spec
from armcal.spec.procedure import CirclePoint
from armcal.spec_parts.robot import SixParameterRobot
from armcal.kinematics.params import joint_kind
from armcal.spec.learned import BASE, JOINT_UNIT
from armcal.effects.types.joint_bending import JointBending
from armcal.effects.types.joint_compliance import JointCompliance
from armcal.effects.types.joint_coupling import JointCoupling

Loc = tuple[str | int, ...]
Problem = tuple[Loc, str]


def check_spec(spec: Spec) -> list[Problem]:
    """All cross-reference problems of a spec that validated field by field."""
    return [*_robot(spec), *_device(spec), *_procedures(spec), *_data(spec), *_report(spec), *_effects(spec), *_residual_model(spec)]


def _robot(spec: Spec) -> Iterator[Problem]:
    robot = spec.robot
    seen: dict[str, int] = {}
    for i, name in enumerate(robot.joint_names()):
        if name in seen:
            yield ("robot", "joints", i, "name"), f"joint name {shown_value(name)} is already used by joint {seen[name] + 1}"
        seen[name] = i
    reserved = {"base", "tool", *seen, *(f"L{i}" for i in range(1, robot.dof + 2)), *robot.link_names()}  # URDF export: a link each
    for name, target in robot.targets.items():
        if name in reserved or "." in name:
            yield ("robot", "targets", name), f"target name {shown_value(name)} clashes with a joint, link, base or tool name"
        if target.link > robot.dof:
            yield (
                ("robot", "targets", name, "link"),
                f"link {target.link} does not exist: this robot has links 0..{robot.dof}",
            )
    yield from _mass_links(robot.masses, ("robot", "masses"), robot.dof)
    yield from _urdf_names(robot)
    if isinstance(robot, SixParameterRobot) and len(robot.links) != robot.dof + 1:
        yield (
            ("robot", "links"),
            f"a six_parameter robot with {robot.dof} joints needs {robot.dof + 1} links, got {len(robot.links)}",
        )


def _urdf_names(robot) -> Iterator[Problem]:
    """robot.urdf names one link per joint, and each URDF link once."""
    if robot.urdf is None:
        return
    if robot.urdf.links and len(robot.urdf.links) != robot.dof:
        yield ("robot", "urdf", "links"), f"{len(robot.urdf.links)} links for {robot.dof} joints: name the link each joint moves, in order"
        return
    names = robot.link_names()
    for name in sorted({name for name in names if names.count(name) > 1}):
        yield ("robot", "urdf"), f"the URDF link name {shown_value(name)} is given twice: the world, each link and the tool are links of their own"


def _mass_links(masses: list, loc: Loc, dof: int) -> Iterator[Problem]:
    for i, mass in enumerate(masses):
        if mass.link > dof:
            yield (*loc, i, "link"), f"link {mass.link} does not exist: masses ride on links 1..{dof}"


def _target_refs(spec: Spec, names: list[str], loc: Loc, what: str) -> Iterator[Problem]:
    for i, name in enumerate(names):
        if name not in spec.robot.targets:
            known = ", ".join(spec.robot.targets) or "none defined"
            yield (*loc, i), f"{what} {shown_value(name)} is not a robot target (targets: {known})"


def _device(spec: Spec) -> Iterator[Problem]:
    yield from spec.device.check(spec)


def _procedures(spec: Spec) -> Iterator[Problem]:
    device = spec.device
    for key in ("procedure", "validation"):
        procedure = getattr(spec, key)
        if procedure is None:
            continue
        if procedure.type not in device.procedures:
            takers = instruments_where(lambda section: procedure.type in section.procedures)
            yield (key, "type"), f"a {procedure.type} procedure needs {with_article(either(takers))} device, not {device.type}"
            continue
        if isinstance(procedure, CirclePoint):
            yield from _circle_point(spec, procedure, (key,))
        yield from device.check_procedure(procedure, (key,))


def _circle_point(spec: Spec, procedure: CirclePoint, loc: Loc) -> Iterator[Problem]:
    robot = spec.robot
    if len(procedure.signature) != robot.dof:
        yield (*loc, "signature"), f"needs {robot.dof} joint values, got {len(procedure.signature)}"
    else:
        for i, (value, joint) in enumerate(zip(procedure.signature, robot.joints)):
            low, high = joint.limits
            if not low <= value <= high:
                yield (*loc, "signature", i), f"joint {i + 1} value lies outside its limits"
    if len(procedure.targets) != robot.dof:
        yield (*loc, "targets"), f"needs one target per joint ({robot.dof}), got {len(procedure.targets)}"
    yield from _target_refs(spec, procedure.targets, (*loc, "targets"), "target")
    for i, name in enumerate(procedure.targets):
        target = robot.targets.get(name)
        if target is not None and target.link != i + 1:
            yield (*loc, "targets", i), f"target {shown_value(name)} is on link {target.link}; joint {i + 1} needs one on link {i + 1}"
    counts = procedure.points_per_joint
    if isinstance(counts, list) and len(counts) != robot.dof:
        yield (*loc, "points_per_joint"), f"needs one count per joint ({robot.dof}), got {len(counts)}"
    for i, n in enumerate(counts if isinstance(counts, list) else [counts]):
        if n < 3:
            yield (*loc, "points_per_joint"), f"a circle needs at least 3 points, got {n}"


def _report(spec: Spec) -> Iterator[Problem]:
    acceptance = spec.acceptance
    if acceptance is None:
        return
    if spec.device.reading_kind != "length":
        lengths = instruments_where(lambda section: section.reading_kind == "length")
        yield ("acceptance",), (f"a {spec.device.type}'s residuals are {spec.device.reading_kind}s; acceptance takes a length tolerance "
                                f"({', '.join(lengths)})")
    if acceptance.statistic.endswith("_3d") and not spec.device.reads_positions:
        yield ("acceptance", "statistic"), f"{acceptance.statistic} needs measured points (a {_positions()}); use validation_rms or validation_max"
    if spec.data is not None and spec.data.validation is None:
        yield ("acceptance", "statistic"), "acceptance judges held-out figures: add data.validation"
    if spec.diagnose.enabled and spec.diagnose.holdout == "validation":
        yield ("acceptance",), "acceptance judges held-out figures, but with diagnose.holdout: validation the diagnosis chose effects with them: use holdout kfold"


def _data(spec: Spec) -> Iterator[Problem]:
    data = spec.data
    if data is not None and data.instrument_moved and not spec.device.reads_positions:
        yield ("data", "instrument_moved"), f"re-registering a moved instrument needs measured positions (a {_positions()})"


def _effects(spec: Spec) -> Iterator[Problem]:
    sections = [("effects",)]
    if spec.simulate is not None:
        sections.append(("simulate", "effects"))
    for loc in sections:
        effects = spec.effects if loc == ("effects",) else spec.simulate.effects  # type: ignore[union-attr]
        seen: dict[tuple, int] = {}
        for i, effect in enumerate(effects):
            what = tuple(getattr(effect, f, None) for f in ("type", "joint", "from_joint", "order", "ratio", "microphone", "pivot"))
            if what in seen:
                yield (*loc, i), f"this {effect.type} effect is already declared as entry {seen[what] + 1}"
            seen.setdefault(what, i)
            needed = accepting(effect.type)
            if needed and spec.device.type not in needed:
                yield (*loc, i, "type"), f"{effect.type} needs {with_article(either(needed))} device, not {spec.device.type}"
            elif needed:
                yield from spec.device.check_effect(effect, (*loc, i))
            joint = getattr(effect, "joint", None)
            if joint is not None and joint > spec.robot.dof:
                yield (*loc, i, "joint"), f"joint {joint} does not exist: this robot has joints 1..{spec.robot.dof}"
            if isinstance(effect, JointCoupling):
                yield from _coupling(spec, effect, (*loc, i))
            if isinstance(effect, JointCompliance) and joint is not None and joint <= spec.robot.dof:
                yield from _compliance(spec, effect, (*loc, i))
            if isinstance(effect, JointBending) and joint is not None and joint <= spec.robot.dof:
                yield from _bending(spec, effect, (*loc, i), simulated=loc != ("effects",))



def _positions() -> str:
    """The instruments whose readings are measured positions."""
    return either(instruments_where(lambda section: section.reads_positions))



def _coupling(spec: Spec, effect: JointCoupling, loc: Loc) -> Iterator[Problem]:
    if effect.from_joint > spec.robot.dof:
        yield (*loc, "from"), f"joint {effect.from_joint} does not exist: this robot has joints 1..{spec.robot.dof}"
    elif effect.from_joint == effect.joint:
        yield (*loc, "from"), "a joint driving itself is its encoder scale: use encoder_scale"


def _compliance(spec: Spec, effect: JointCompliance, loc: Loc) -> Iterator[Problem]:
    """The keys of each form belong to it; a moments product names a link beyond the joint and an axis."""
    products = sorted(effect.model_extra or {})
    revolute = spec.robot.joints[effect.joint - 1].type == "revolute"
    if effect.form == "masses":
        yield from _mass_links(effect.masses, (*loc, "masses"), spec.robot.dof)
        for key in [*products, *(["w"] if effect.w is not None else [])]:
            yield (*loc, key), f"{key} is a product of the moments form: add form: moments, or give masses and compliance"
        return
    for key in ("compliance", "masses"):
        if key in effect.model_fields_set:
            yield (*loc, key), f"{key} belongs to form: masses; the moments form identifies the products m<c><k> (or w) instead"
    if not revolute:
        for key in products:
            yield (*loc, key), f"joint {effect.joint} is prismatic: its compliance under gravity has the one product w"
        return
    if effect.w is not None:
        yield (*loc, "w"), f"w is the product of a prismatic joint; joint {effect.joint} is revolute (products m<c><k>)"
    for key in products:
        link = int(key[2:])  # m<c><k>: the loader checked the form
        if not effect.joint <= link <= spec.robot.dof:
            yield (*loc, key), f"link {link} is not beyond joint {effect.joint}: the products name links {effect.joint}..{spec.robot.dof}"


def _bending(spec: Spec, effect: JointBending, loc: Loc, simulated: bool) -> Iterator[Problem]:
    if simulated:
        yield (*loc, "type"), "armcal simulate moves the true robot's joints only and cannot bend it: declare joint_bending under effects:"
    if spec.robot.joints[effect.joint - 1].type != "revolute":
        yield (*loc, "joint"), f"joint {effect.joint} is prismatic: bending is modelled for revolute joints"
        return
    for key in sorted(effect.model_extra or {}):
        link = int(key[2:])
        if not effect.joint <= link <= spec.robot.dof:
            yield (*loc, key), f"link {link} is not beyond joint {effect.joint}: the products name links {effect.joint}..{spec.robot.dof}"


def _residual_model(spec: Spec) -> Iterator[Problem]:
    if spec.residual_model is not None:
        yield from residual_model_problems(spec.residual_model, spec.robot)


def residual_model_problems(model, robot) -> Iterator[Problem]:
    """A stored learned model (spec/learned.py) is of this robot: a value per joint in every row and length scale,
    its joints' units, a point's coordinates at one of its targets."""
    units = [JOINT_UNIT[joint_kind(joint.type)] for joint in robot.joints]
    if model.joint_units != units:
        yield ("residual_model", "joint_units"), f"the robot's joints are in {units}, not {model.joint_units}: a model of another robot"
    for i, coordinate in enumerate(model.coordinates):
        if coordinate.coordinate in BASE and coordinate.at not in robot.targets:
            yield ("residual_model", "coordinates", i, "at"), (f"{shown_value(coordinate.at)} is not one of the robot's targets "
                                                            f"({', '.join(robot.targets)}): a point's error is learned at a target")
        if len(coordinate.length_scales) != robot.dof:
            yield ("residual_model", "coordinates", i, "length_scales"), f"{len(coordinate.length_scales)} length scales for {robot.dof} joints: one per joint"
        wrong = next((r for r, row in enumerate(coordinate.inputs) if len(row) != robot.dof), None)
        if wrong is not None:
            yield ("residual_model", "coordinates", i, "inputs", wrong), f"{len(coordinate.inputs[wrong])} joint values for {robot.dof} joints: one per joint"
