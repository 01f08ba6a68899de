"""Mimic joints on a URDF chain, replaced by the joint they mimic (their master), which becomes one armcal joint.

URDF moves a mimic joint by m q + o, q its master's value. On the chain from BASE to TIP, the mimics of one master
with only fixed joints between them make one group, moved by the master's value. Prismatic mimics are exact for any
multipliers: their translations Trans(a_i (m_i q + o_i)) commute to the front of the group, A_1 Trans(v_1) A_2 ... =
Trans(R_1 v_1 + R_2 v_2 + ...) A_1 A_2 ..., R_i the rotation of A_1 ... A_i, so the group moves by Trans(d q + c) A,
d = sum m_i R_i a_i, c = sum o_i R_i a_i: a prismatic joint along d / |d| after Trans(c), if |d| = 1 (armcal's
joints move as their reading does). A revolute group is one mimic with multiplier 1: Rot(a, q + o) = Rot(a, o)
Rot(a, q). Anything else is refused: a master on the chain with its mimics, or one master in two groups (two joints
moved by one value), a mimic of a mimic, of a joint of another kind, or of none.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING
from xml.etree import ElementTree as ET

import numpy as np

from armcal.support.errors import shown_text
from armcal.kinematics.transforms import trans

if TYPE_CHECKING:
    from armcal.importers.urdf import _Document

MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}  # URDF joint type: the armcal joint it makes
UNIT_GEAR = 1e-12  # |d| within this of 1: the group moves 1 mm per mm of its master


@dataclass(frozen=True)
class Mimic:
    master: ET.Element  # the joint it mimics
    multiplier: float
    offset: float  # mm or rad
    group: tuple[ET.Element, ...]  # the mimics of its group, in chain order


def mimics_on(document: _Document, moving: list[ET.Element]) -> dict[ET.Element, Mimic]:
    """Each mimic joint among the chain's ``moving`` joints (in chain order, their types already known to be
    revolute, continuous or prismatic), checked to make groups armcal imports."""
    joints = {joint.get("name"): joint for joint in document.root.findall("joint")}
    groups: list[tuple[list[ET.Element], ET.Element]] = []
    last = None  # the group of the moving joint before (None: that joint mimics none)
    for joint in moving:
        master = _master(document, joint, joints)
        if master is None:
            last = None
        elif last is not None and last[1] is master:
            last[0].append(joint)
        else:
            last = ([joint], master)
            groups.append(last)
    out, seen = {}, {}
    for group, master in groups:
        first = group[0]
        if master in moving:
            raise document.error(first, f"joint '{_shown(first)}' mimics '{_shown(master)}', which is on the chain too (line {document.lines[master]}): "
                                        "armcal's joints move each by a value of its own (two joints moved by one value are not imported)")
        if master in seen:
            raise document.error(first, f"joint '{_shown(first)}' mimics '{_shown(master)}' as '{_shown(seen[master])}' (line {document.lines[seen[master]]}) does, "
                                        "with a moving joint between them: armcal's joints move each by a value of its own (two joints moved by one value are not imported)")
        seen[master] = first
        for joint in group:
            out[joint] = _mimic(document, joint, master, tuple(group))
    return out


def _shown(joint: ET.Element) -> str:
    """A joint's name as a message shows it (errors.shown_text)."""
    return shown_text(joint.get("name", "?"), "a name")


def _master(document: _Document, joint: ET.Element, joints: dict[str, ET.Element]) -> ET.Element | None:
    """The joint ``joint`` mimics (None: it mimics none), checked to be a joint of its kind that mimics none."""
    element = joint.find("mimic")
    if element is None:
        return None
    name, kind = _shown(joint), joint.get("type")
    if not element.get("joint"):
        raise document.error(element, f"joint '{name}': <mimic> needs the attribute joint (the joint it mimics)")
    master = joints.get(element.get("joint"))
    if master is None:
        raise document.error(element, f"joint '{name}' mimics '{shown_text(element.get('joint'), 'a name')}', which is no joint of the file")
    if master.find("mimic") is not None:
        raise document.error(element, f"joint '{name}' mimics '{_shown(master)}', itself a mimic joint (line {document.lines[master]}): "
                                      "armcal imports mimic joints of a joint that moves on its own")
    if MOVING.get(master.get("type")) != MOVING[kind]:
        raise document.error(element, f"joint '{name}' ({kind}) mimics '{_shown(master)}' ({shown_text(master.get('type'), 'a type')}, line {document.lines[master]}): "
                                      "armcal imports mimic joints of a joint of their kind (revolute or continuous, or prismatic)")
    return master


def _mimic(document: _Document, joint: ET.Element, master: ET.Element, group: tuple[ET.Element, ...]) -> Mimic:
    """``joint``'s multiplier and offset (in mm or rad), a revolute group checked to be one mimic of multiplier 1."""
    element, name = joint.find("mimic"), _shown(joint)
    (multiplier,) = document.numbers(element, "multiplier", 1, "1")
    (offset,) = document.numbers(element, "offset", 1, "0", *(("length", "m") if joint.get("type") == "prismatic" else ("angle", "rad")))
    if MOVING[joint.get("type")] == "revolute":
        if len(group) > 1:
            raise document.error(group[1], f"joint '{_shown(group[1])}' mimics '{_shown(master)}' as '{_shown(group[0])}' "
                                           f"(line {document.lines[group[0]]}) does: armcal imports one revolute mimic joint per master")
        if multiplier != 1:
            raise document.error(element, f"joint '{name}' mimics '{_shown(master)}' with multiplier {multiplier:g}: armcal imports a "
                                           "revolute mimic joint that turns as its master does (multiplier 1)")
    return Mimic(master, float(multiplier), float(offset), group)


class Slide:
    """A group of prismatic mimics, their translations gathered at its start: Trans(d q + c) A, A its fixed part."""

    def __init__(self):
        self.d, self.c, self.multipliers = np.zeros(3), np.zeros(3), []

    def add(self, frame: np.ndarray, axis: np.ndarray, mimic: Mimic) -> None:
        """One mimic, its unit ``axis`` in ``frame`` (the group's fixed part so far, this joint's origin included)."""
        along = frame[:3, :3] @ axis
        self.d += mimic.multiplier * along
        self.c += mimic.offset * along
        self.multipliers.append(mimic.multiplier)

    def joint(self, document: _Document, mimic: Mimic) -> tuple[np.ndarray, np.ndarray]:
        """(Trans(c), the unit direction d / |d|), the group checked to move 1 mm per mm of its master."""
        gear = float(np.linalg.norm(self.d))
        if abs(gear - 1.0) > UNIT_GEAR:
            names = ", ".join(f"'{_shown(j)}'" for j in mimic.group)
            multipliers = ", ".join(f"{m:g}" for m in self.multipliers)
            plural = "s" if len(mimic.group) > 1 else ""
            raise document.error(mimic.group[0], f"joint{plural} {names} mimicking '{_shown(mimic.master)}' with multiplier{plural} {multipliers} "
                                                 f"move the chain {gear:.12g} mm per mm of '{_shown(mimic.master)}', and armcal's joints move as "
                                                 "their reading does (1 mm per mm): not imported")
        return trans(*self.c), self.d / gear
