"""Cross-reference checks that a single field cannot make on its own.

Each check yields (location, message) where location is the path of the field
in the spec, so the loader can name file, line and column.
"""

from __future__ import annotations

from collections.abc import Iterator

from armcal.errors import with_article
from armcal.spec.device import BallBar, SonicDigitizer, Theodolite, Tracker
from armcal.spec.model import Spec
from armcal.spec.procedure import CirclePoint, Poses, Shells
from armcal.spec.robot import SixParameterRobot
from armcal.spec.sections import JointBending, JointCompliance, JointCoupling, PivotOffset, RangeBias

Loc = tuple[str | int, ...]
DEVICES_OF_EFFECT = {  # instrument-side effects and the devices they act on
    "sensor_scale": ("sonic_digitizer", "tracker"),  # scales measured lengths
    "ballbar_length": ("ballbar",),
}
Problem = tuple[Loc, str]


def check_spec(spec: Spec) -> list[Problem]:
    """All cross-reference problems of a spec that validated field by field."""
    return [*_robot(spec), *_device(spec), *_procedures(spec), *_data(spec), *_report(spec), *_effects(spec)]


def _robot(spec: Spec) -> Iterator[Problem]:
    robot = spec.robot
    seen: dict[str, int] = {}
    for i, name in enumerate(robot.joint_names()):
        if name in seen:
            yield ("robot", "joints", i, "name"), f"joint name '{name}' is already used by joint {seen[name] + 1}"
        seen[name] = i
    reserved = {"base", "tool", *seen, *(f"L{i}" for i in range(1, robot.dof + 2))}
    for name, target in robot.targets.items():
        if name in reserved or "." in name:
            yield ("robot", "targets", name), f"target name '{name}' clashes with a joint, link, base or tool name"
        if target.link > robot.dof:
            yield (
                ("robot", "targets", name, "link"),
                f"link {target.link} does not exist: this robot has links 0..{robot.dof}",
            )
    yield from _mass_links(robot.masses, ("robot", "masses"), robot.dof)
    if isinstance(robot, SixParameterRobot) and len(robot.links) != robot.dof + 1:
        yield (
            ("robot", "links"),
            f"a six_parameter robot with {robot.dof} joints needs {robot.dof + 1} links, got {len(robot.links)}",
        )


def _mass_links(masses: list, loc: Loc, dof: int) -> Iterator[Problem]:
    for i, mass in enumerate(masses):
        if mass.link > dof:
            yield (*loc, i, "link"), f"link {mass.link} does not exist: masses ride on links 1..{dof}"


def _target_refs(spec: Spec, names: list[str], loc: Loc, what: str) -> Iterator[Problem]:
    for i, name in enumerate(names):
        if name not in spec.robot.targets:
            known = ", ".join(spec.robot.targets) or "none defined"
            yield (*loc, i), f"{what} '{name}' is not a robot target (targets: {known})"


def _device(spec: Spec) -> Iterator[Problem]:
    device = spec.device
    if isinstance(device, BallBar):
        yield from _target_refs(spec, device.spheres, ("device", "spheres"), "sphere")
    elif isinstance(device, (Theodolite, Tracker)):
        yield from _target_refs(spec, device.targets, ("device", "targets"), "target")
        if isinstance(device, Tracker) and device.orientation and device.orientation_noise is None:
            yield ("device", "orientation_noise"), "a tracker that measures orientation needs orientation_noise (its sigma)"
    elif isinstance(device, SonicDigitizer):
        for i, rod in enumerate(device.calibration_rods):
            if rod.microphone not in device.microphones:
                yield (
                    ("device", "calibration_rods", i, "microphone"),
                    f"microphone '{rod.microphone}' is not in device.microphones",
                )


def _procedures(spec: Spec) -> Iterator[Problem]:
    for key in ("procedure", "validation"):
        procedure = getattr(spec, key)
        if isinstance(procedure, CirclePoint):
            yield from _circle_point(spec, procedure, (key,))
        elif isinstance(procedure, Shells):
            yield from _shells(spec, procedure, (key,))
        elif isinstance(procedure, Poses):
            if isinstance(spec.device, BallBar):
                if procedure.file is None:
                    yield (key, "count"), "a ball-bar's poses come from a file with pivot and sphere columns (armcal plan writes one), not count"
            elif not isinstance(spec.device, Tracker | Theodolite):
                yield (key, "type"), f"a poses procedure needs a tracker, theodolite or ball-bar, not {spec.device.type}"
            if (procedure.file is None) == (procedure.count is None):
                yield (key,), "give either a pose file (file) or a number of random poses (count)"


def _circle_point(spec: Spec, procedure: CirclePoint, loc: Loc) -> Iterator[Problem]:
    robot = spec.robot
    if not isinstance(spec.device, SonicDigitizer | Tracker):
        yield (*loc, "type"), f"circle_point needs a device that measures target positions (sonic_digitizer, tracker), not {spec.device.type}"
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
            yield (*loc, "targets", i), f"target '{name}' is on link {target.link}; joint {i + 1} needs one on link {i + 1}"
    counts = procedure.points_per_joint
    if isinstance(counts, list) and len(counts) != robot.dof:
        yield (*loc, "points_per_joint"), f"needs one count per joint ({robot.dof}), got {len(counts)}"
    for i, n in enumerate(counts if isinstance(counts, list) else [counts]):
        if n < 3:
            yield (*loc, "points_per_joint"), f"a circle needs at least 3 points, got {n}"


def _shells(spec: Spec, procedure: Shells, loc: Loc) -> Iterator[Problem]:
    device = spec.device
    if not isinstance(device, BallBar):
        yield (*loc, "type"), f"shells needs a ballbar device, not {device.type}"
        return
    for i, pairing in enumerate(procedure.pairings):
        if pairing.pivot not in device.pivots:
            yield (*loc, "pairings", i, "pivot"), f"pivot '{pairing.pivot}' is not in device.pivots"
        if pairing.sphere not in device.spheres:
            yield (*loc, "pairings", i, "sphere"), f"sphere '{pairing.sphere}' is not in device.spheres"
    if procedure.extension is not None and procedure.extension not in device.extension_rods:
        yield (*loc, "extension"), f"extension rod '{procedure.extension}' is not in device.extension_rods"


def _report(spec: Spec) -> Iterator[Problem]:
    acceptance = spec.acceptance
    if acceptance is None:
        return
    if isinstance(spec.device, Theodolite):
        yield ("acceptance",), "a theodolite's residuals are angles; acceptance takes a length tolerance (tracker, ball-bar, sonic digitizer)"
    if acceptance.statistic.endswith("_3d") and not isinstance(spec.device, Tracker):
        yield ("acceptance", "statistic"), f"{acceptance.statistic} needs measured points (a tracker); use validation_rms or validation_max"
    if spec.data is not None and spec.data.validation is None:
        yield ("acceptance", "statistic"), "acceptance judges held-out figures: add data.validation"
    if spec.diagnose.enabled and spec.diagnose.holdout == "validation":
        yield ("acceptance",), "acceptance judges held-out figures, but with diagnose.holdout: validation the diagnosis chose effects with them: use holdout kfold"


def _data(spec: Spec) -> Iterator[Problem]:
    data = spec.data
    if data is not None and data.instrument_moved and not isinstance(spec.device, Tracker):
        yield ("data", "instrument_moved"), "re-registering a moved instrument needs a tracker (measured positions)"


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
            needed = DEVICES_OF_EFFECT.get(effect.type)
            if needed and spec.device.type not in needed:
                yield (*loc, i, "type"), f"{effect.type} needs {with_article(' or '.join(needed))} device, not {spec.device.type}"
            joint = getattr(effect, "joint", None)
            if joint is not None and joint > spec.robot.dof:
                yield (*loc, i, "joint"), f"joint {joint} does not exist: this robot has joints 1..{spec.robot.dof}"
            if isinstance(effect, RangeBias) and (
                not isinstance(spec.device, SonicDigitizer) or effect.microphone not in spec.device.microphones
            ):
                yield (*loc, i, "microphone"), f"microphone '{effect.microphone}' is not in device.microphones"
            if isinstance(effect, JointCoupling):
                yield from _coupling(spec, effect, (*loc, i))
            if isinstance(effect, JointCompliance) and joint is not None and joint <= spec.robot.dof:
                yield from _compliance(spec, effect, (*loc, i))
            if isinstance(effect, JointBending) and joint is not None and joint <= spec.robot.dof:
                yield from _bending(spec, effect, (*loc, i), simulated=loc != ("effects",))
            if isinstance(effect, PivotOffset) and (
                not isinstance(spec.device, BallBar) or effect.pivot not in spec.device.pivots
            ):
                yield (*loc, i, "pivot"), f"pivot '{effect.pivot}' is not in device.pivots"


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
