"""A serial chain read from a URDF file: the joints from one link to another, fixed joints merged, mimic joints
replaced by the joint they mimic (mimic.py).

URDF (ROS's robot description) writes each joint as child = parent * origin(xyz, rpy) * motion, the origin's
rotation R = Rz(yaw) Ry(pitch) Rx(roll), the motion Rot(axis, q) (revolute, continuous) or Trans(q axis)
(prismatic), lengths in metres. armcal's joints move about z: with S a rotation taking z onto the axis,
Rot(axis, q) = S Rot(z, q) S^-1 (likewise the translation), so S ends the fixed transform before the joint and
S^-1 starts the next one; fixed joints multiply into the transform they sit in (their inverse where the chain
climbs from BASE to a link above TIP, as from ROS-Industrial's base to base_link). The chain is then
T = links[0] J_1(q_1) links[1] ... J_n(q_n) links[n], J_i = Rot(z, q_i) or Trans(0, 0, q_i), in mm. Each moving
joint keeps the name of the link it moves and that link's frame S^-1 in the frame the joint turns (a group of
mimic joints: the name, type and limits of their master, and the link the last of them moves).

The file is only parsed, never run: no xacro, no DOCTYPE (so no entities to expand), meshes, inertias and
everything else off the chain ignored. What is read is checked whole: the joints must make one tree from a single
root link (links and joints named once, each joint joining two declared links, no cycle), every number must be
finite and of a magnitude armcal computes with (units.to_internal: at most 1e9 mm or rad; below 1e-30, rounding
dust, read as 0), and the chain may have no more joints than a spec file holds (MAX_JOINTS).
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET
from xml.parsers import expat

import numpy as np

from armcal.support.errors import UserError, shown_text
from armcal.support.fileio import INPUT_LIMITS, read_input
from armcal.importers.mimic import MOVING, Slide, mimics_on
from armcal.kinematics.transforms import compose, inverse, rot_x, rot_y, rot_z, trans
from armcal.support.units import INTERNAL_UNIT, LARGEST, SMALLEST, factor, parse_number, to_internal

CONTINUOUS_LIMITS = (-2 * np.pi, 2 * np.pi)  # rad: a continuous joint's limits in the spec, one turn either way
MAX_JOINTS = INPUT_LIMITS["spec"] // 128  # a spec file holds no more moving joints: each takes over 128 bytes of it
XML_SPACE = re.compile(r"[ \t\r\n]+")  # what separates numbers in an attribute (XML's white space; no Unicode spaces)
LISTED = 12  # names a message lists before '... and N more'


@dataclass(frozen=True)
class UrdfJoint:
    name: str
    type: str  # revolute or prismatic
    limits: tuple[float, float]  # rad or mm
    continuous: bool
    link: str  # the link it moves (its child)
    frame: np.ndarray  # that link's frame in the frame the joint turns, z on the axis: S^-1 (a mimic group: S^-1 A, moved across the axis) (mm)


@dataclass(frozen=True)
class UrdfChain:
    robot: str
    joints: tuple[UrdfJoint, ...]
    links: tuple[np.ndarray, ...]  # n + 1 fixed transforms (mm): T = links[0] J_1 links[1] ... J_n links[n]
    merged: tuple[str, ...]  # the fixed joints multiplied into the links
    mimicked: tuple[tuple[str, tuple[str, ...]], ...] = ()  # (master, its mimic joints replaced by it), mimic.py
    path: Path | None = None  # the URDF file read

    def axes(self) -> list[np.ndarray]:
        """The frames joints 1..n turn, z on their axes, in BASE at q = 0: links[0] links[1] ... links[i - 1]."""
        out = [self.links[0]]
        for link in self.links[1:-1]:
            out.append(out[-1] @ link)
        return out


class _Document:
    """The elements of a URDF file and the line each starts on, parsed with expat, DOCTYPE refused."""

    def __init__(self, path: Path, data: bytes):
        self.path, self.lines = path, {}
        self.links: dict[str, ET.Element] = {}  # by name, once _tree checked them
        builder = ET.TreeBuilder()
        parser = expat.ParserCreate()

        def start(tag, attributes):
            self.lines[builder.start(tag, attributes)] = parser.CurrentLineNumber

        def doctype(*_):
            raise UserError(f"{path}:{parser.CurrentLineNumber}: the file has a DOCTYPE; a URDF needs none, and armcal reads none (entities are not expanded)")

        parser.StartElementHandler, parser.EndElementHandler = start, builder.end
        parser.CharacterDataHandler, parser.StartDoctypeDeclHandler = builder.data, doctype
        try:
            parser.Parse(data, True)
        except expat.ExpatError as exc:
            raise UserError(f"{path}:{exc.lineno}:{exc.offset + 1}: not XML: {expat.ErrorString(exc.code)}") from None
        self.root = builder.close()

    def error(self, element: ET.Element, message: str) -> UserError:
        return UserError(f"{self.path}:{self.lines[element]}: {message}")

    def numbers(self, element: ET.Element, attribute: str, count: int, default: str | None = None,
                kind: str = "scale", unit: str = "1") -> np.ndarray:
        """``count`` numbers of an attribute, in ``unit`` of ``kind``, as internal values (mm, rad): each finite and at
        most the magnitude armcal computes with (units.to_internal), below its smallest 0, so nothing overflows in the
        spec written."""
        text = element.get(attribute, default)
        if text is None:
            raise self.error(element, f"<{element.tag}> needs the attribute {attribute}")
        value = shown_text(text, "a value")
        shown = f"<{element.tag} {attribute}=\"{text}\">" if value == text else f"<{element.tag} {attribute}> ({value})"
        try:
            values = np.array([parse_number(v) for v in XML_SPACE.split(text.strip(" \t\r\n")) if v])
        except ValueError:
            hint = " (a xacro expression? run xacro first)" if "$" in text else ""
            raise self.error(element, f"{shown}: not {count} number{'s' if count > 1 else ''}{hint}") from None
        if len(values) != count or not np.all(np.isfinite(values)):
            raise self.error(element, f"{shown}: not {count} finite number{'s' if count > 1 else ''}")
        internal = []
        for value in values:
            try:  # rounding dust (armcal's own URDF export writes 3.6e-35 m) is 0, as units.snapped writes it
                internal.append(0.0 if abs(float(value) * factor(kind, unit)) < SMALLEST else to_internal(float(value), kind, unit))
            except ValueError:
                suffix, inside = (f" {unit}", f" {INTERNAL_UNIT[kind]}") if kind in ("length", "angle") else ("", "")
                raise self.error(element, f"{shown}: {value:g}{suffix} lies outside what armcal computes with: "
                                          f"magnitudes {SMALLEST:g} to {LARGEST:g}{inside}, or 0") from None
        return np.array(internal)


def read_urdf(path: Path, base: str, tip: str) -> UrdfChain:
    """The chain of ``path``'s URDF from link ``base`` to link ``tip``."""
    document = _Document(path, read_input(path, "urdf"))
    root = document.root
    if root.tag != "robot":
        raise document.error(root, f"the top element is <{root.tag}>, not a URDF's <robot>")
    xacro = next((e for e in root.iter() if e.tag.startswith("xacro:")), None)
    if xacro is not None:
        raise document.error(xacro, f"<{xacro.tag}>: this is a xacro file; armcal runs nothing, expand it first (xacro FILE > robot.urdf)")
    chain = _joints_between(document, base, tip)
    moving = [element for element, _ in chain if element.get("type") != "fixed"]
    if len(moving) > MAX_JOINTS:
        raise UserError(f"{path}: {len(moving)} joints from '{base}' to '{tip}': a spec file holds at most {MAX_JOINTS} "
                        f"(it may have {INPUT_LIMITS['spec'] >> 10} KiB)")
    for element in moving:
        name, kind = element.get("name", "?"), element.get("type")
        if kind is None:
            raise document.error(element, f"joint '{name}' has no type (revolute, continuous, prismatic or fixed)")
        if kind not in MOVING:
            raise document.error(element, f"joint '{name}' is {kind}; armcal imports revolute, continuous, prismatic and fixed joints")
    mimics = mimics_on(document, moving)
    joints, links, merged, mimicked = [], [], [], []
    pending = np.eye(4)
    for element, upwards in chain:
        origin = _origin(document, element.find("origin"))
        if element.get("type") == "fixed":
            pending = pending @ (inverse(origin) if upwards else origin)
            merged.append(element.get("name", "?"))
            continue
        axis, mimic, turn = _axis(document, element), mimics.get(element), 0.0
        if mimic is None:
            before, after = pending @ origin, np.eye(4)
        elif element.get("type") == "prismatic":  # the group's translations gathered at its start, its origins in pending
            if element is mimic.group[0]:
                start, pending, slide = pending, np.eye(4), Slide()
            pending = pending @ origin
            slide.add(pending, axis, mimic)
            if element is not mimic.group[-1]:
                continue
            offset, axis = slide.joint(document, mimic)
            before, after = start @ offset, pending
        else:  # Rot(axis, q + offset) = S Rot(z, offset) Rot(z, q) S^-1
            before, after, turn = pending @ origin, np.eye(4), mimic.offset
        S = _z_onto(axis)
        across = trans(*(S.T @ after)[:2, 3], 0.0)  # a slide's frame moves freely across its axis: onto its link's origin (robot.urdf has no x, y)
        links.append(before @ S @ across @ rot_z(turn))
        pending = inverse(across) @ S.T @ after
        source = element if mimic is None else mimic.master
        if mimic is not None:
            mimicked.append((source.get("name"), tuple(j.get("name") for j in mimic.group)))
        kind = source.get("type")
        joints.append(UrdfJoint(source.get("name", "?"), MOVING[kind], _limits(document, source, kind), kind == "continuous",
                                element.find("child").get("link"), pending))
    if not joints:
        raise UserError(f"{path}: no revolute, continuous or prismatic joint between '{base}' and '{tip}'")
    links.append(pending)
    return UrdfChain(root.get("name", "robot"), tuple(joints), tuple(links), tuple(merged), tuple(mimicked), Path(path))


def _joints_between(document: _Document, base: str, tip: str) -> list[tuple[ET.Element, bool]]:
    """(joint, upwards) from link ``base`` to link ``tip``: up from ``base`` through fixed joints (upwards True)
    to the first link above ``tip`` (ROS-Industrial's ``base`` hangs from ``base_link``), then down to ``tip``."""
    parent_joint = _tree(document)
    for name in (base, tip):
        if name not in document.links:
            raise UserError(f"{document.path}: no link '{name}'; the links are {_listed(list(document.links))}")
    above_tip = _above(parent_joint, tip)
    names_above_tip = [link for link, _ in above_tip]
    up = []
    for link, joint in _above(parent_joint, base):  # ends at the root, which is above tip too
        if link in names_above_tip:
            break
        up.append(joint)
    moving = next((j for j in up if j.get("type") != "fixed"), None)
    if moving is not None:
        raise UserError(f"{document.path}: no chain from '{base}' to '{tip}': '{base}' is neither a link above '{tip}' "
                        f"({_listed(names_above_tip[1:]) if len(names_above_tip) > 1 else 'none'}) nor one fixed to such a link")
    down = [joint for _, joint in above_tip[: names_above_tip.index(link)]]
    return [(joint, True) for joint in up] + [(joint, False) for joint in down[::-1]]


def _tree(document: _Document) -> dict[str, ET.Element]:
    """Each link's parent joint (the root link has none), the URDF checked to be one tree from a single root:
    links and joints named once, each joint joining two declared links, no link the child of two joints or of
    itself, one link that is no joint's child and every other link below it (no cycle)."""
    declared: dict[tuple[str, str], ET.Element] = {}
    for element in (*document.root.findall("link"), *document.root.findall("joint")):
        name = element.get("name")
        if not name:
            raise document.error(element, f"<{element.tag}> needs a name")
        if (element.tag, name) in declared:
            raise document.error(element, f"{element.tag} '{name}' is declared twice (first on line {document.lines[declared[element.tag, name]]})")
        declared[element.tag, name] = element
    document.links = {name: element for (tag, name), element in declared.items() if tag == "link"}
    parent_joint: dict[str, ET.Element] = {}
    children: dict[str, list[str]] = defaultdict(list)
    for joint in document.root.findall("joint"):
        name = joint.get("name")
        parent, child = (joint.find(role) for role in ("parent", "child"))
        if parent is None or child is None or not parent.get("link") or not child.get("link"):
            raise document.error(joint, f"joint '{name}' needs <parent link=...> and <child link=...>")
        parent, child = parent.get("link"), child.get("link")
        for role, link in (("parent", parent), ("child", child)):
            if link not in document.links:
                raise document.error(joint, f"joint '{name}': its {role} link '{link}' is no <link> of the file")
        if parent == child:
            raise document.error(joint, f"joint '{name}' joins link '{child}' to itself; a URDF is a tree")
        if child in parent_joint:
            raise document.error(joint, f"link '{child}' is the child of two joints (the other on line {document.lines[parent_joint[child]]}); a URDF is a tree")
        parent_joint[child] = joint
        children[parent].append(child)
    roots = [link for link in document.links if link not in parent_joint]
    if len(roots) > 1:
        raise UserError(f"{document.path}: {len(roots)} links are no joint's child ({_listed(roots)}); a URDF is one tree from a single root link")
    below, stack = set(roots), list(roots)
    while stack:
        for child in children[stack.pop()]:
            below.add(child)
            stack.append(child)
    link = next((link for link in document.links if link not in below), None)
    if link is not None:  # below no root: up from it, the joints go round a cycle
        on_path = []
        while link not in on_path:
            on_path.append(link)
            link = parent_joint[link].find("parent").get("link")
        cycle = on_path[on_path.index(link):][::-1]  # parent to child
        order = {name: i for i, name in enumerate(document.links)}
        first = min(range(len(cycle)), key=lambda i: order[cycle[i]])  # from its first declared link
        cycle = cycle[first:] + cycle[:first]
        where = f"none of them below the root link '{roots[0]}'" if roots else "every link is a joint's child, so none is the root"
        raise document.error(parent_joint[cycle[0]], f"the joints form a cycle ({' -> '.join([*cycle, cycle[0]])}: {where}); a URDF is a tree")
    return parent_joint


def _listed(names: list[str]) -> str:
    """Names for a message: the first LISTED of them, then how many more."""
    more = f", ... ({len(names) - LISTED} more)" if len(names) > LISTED else ""
    return ", ".join(names[:LISTED]) + more if names else "(none)"


def _above(parent_joint: dict[str, ET.Element], link: str) -> list[tuple[str, ET.Element | None]]:
    """(link, the joint whose child it is) from ``link`` up to the root (whose joint is None); the links are a tree."""
    out = [(link, parent_joint.get(link))]
    while out[-1][1] is not None:
        link = out[-1][1].find("parent").get("link")
        out.append((link, parent_joint.get(link)))
    return out


def _origin(document: _Document, element: ET.Element | None) -> np.ndarray:
    """Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll) of an <origin> (identity when absent), in mm."""
    if element is None:
        return np.eye(4)
    x, y, z = document.numbers(element, "xyz", 3, "0 0 0", "length", "m")
    roll, pitch, yaw = document.numbers(element, "rpy", 3, "0 0 0", "angle", "rad")
    return compose(trans(x, y, z), rot_z(yaw), rot_y(pitch), rot_x(roll))


def _axis(document: _Document, joint: ET.Element) -> np.ndarray:
    """The unit vector of a joint's <axis> (URDF's default 1 0 0 when absent)."""
    element = joint.find("axis")
    axis = document.numbers(element, "xyz", 3, default="1 0 0") if element is not None else np.array([1.0, 0.0, 0.0])
    if np.linalg.norm(axis) < 1e-9:
        raise document.error(element, f"joint '{joint.get('name', '?')}': the axis is zero")
    return axis / np.linalg.norm(axis)


def _z_onto(axis: np.ndarray) -> np.ndarray:
    """The rotation taking z onto the unit vector ``axis``: about z x axis, or half a turn about x for -z."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, axis), float(axis @ z)
    S = np.eye(4)
    if c < -1.0 + 1e-12:
        S[:3, :3] = np.diag([1.0, -1.0, -1.0])
    else:
        K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        S[:3, :3] = np.eye(3) + K + K @ K / (1.0 + c)
    return S


def _limits(document: _Document, joint: ET.Element, kind: str) -> tuple[float, float]:
    """(lower, upper) in rad or mm: the <limit>'s, a continuous joint's CONTINUOUS_LIMITS."""
    if kind == "continuous":
        return CONTINUOUS_LIMITS
    name, limit = joint.get("name", "?"), joint.find("limit")
    if limit is None:
        raise document.error(joint, f"joint '{name}' ({kind}) has no <limit>; URDF requires one")
    quantity = ("length", "m") if kind == "prismatic" else ("angle", "rad")
    (low,), (high,) = document.numbers(limit, "lower", 1, "0", *quantity), document.numbers(limit, "upper", 1, "0", *quantity)
    if low >= high:
        scale = 1000.0 if kind == "prismatic" else 1.0
        raise document.error(limit, f"joint '{name}': the lower limit {low / scale:g} is not below the upper limit {high / scale:g}")
    return low, high
