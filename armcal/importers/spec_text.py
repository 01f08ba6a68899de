"""A URDF chain as a spec's text, in dh, mdh or six_parameter, with stand-ins (its placeholders) for the serial, target, device and procedure.

The convention is the simplest the chain's axes allow, unless one is asked for: ``dh`` (Stone (2.9)) when every
pair of consecutive axes is parallel or has a common normal near them (kinematics/dh_rows.py), else ``mdh`` (Hayati's
beta for the near-parallel pairs), else ``six_parameter`` (Goswami (3): link i = Trans(x, y, z) Rot(z, alpha)
Rot(y, beta) Rot(x, gamma), joint theta = theta0 + k q (2), here theta0 = 0 and k = 1 fixed; the chain's links[i - 1]
is link i, link n + 1 the identity). Every convention starts at link BASE (the world) and ends at link TIP (the tool).
Values are written in mm and deg with 15 significant digits (limits 12; below 1e-12, 0), so the spec's forward
kinematics is the URDF's to 1e-9 mm. The URDF's names and each moved link's frame in the frame its joint turns go
into ``robot.urdf``, for export --format urdf. The text is checked as ``armcal validate`` checks the file: within a
spec file's size and valid; a dh or mdh chain whose values leave armcal's range falls back to six_parameter.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal.support.errors import SpecError, UserError
from armcal.support.fileio import INPUT_LIMITS
from armcal.importers.urdf import UrdfChain
from armcal.kinematics.dh_rows import DHChain, dh_chain
from armcal.kinematics.transforms import inverse, pose_from_matrix
from armcal.spec.loader import spec_from_bytes
from armcal.spec.placeholders import marker_lines
from armcal.support.units import snapped

CONVENTIONS = ("dh", "mdh", "six_parameter")  # simplest first
LINK = ("x", "y", "z", "alpha", "beta", "gamma")  # Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma)
POSE = ("x", "y", "z", "rz", "ry", "rx")  # Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx): the same product
LINK_FRAME = ("", "", "z", "rz", "ry", "rx")  # no x, y: a URDF link's origin lies on its joint's axis
TARGET = "tool_point"
OFF_AXIS = 50.0  # mm: the stand-in target's distance from the last joint's axis beyond the tool's origin (the tracker guide's reflector)
quoted = json.dumps  # a JSON string is a YAML string: names and paths are written as data, whatever they hold


@dataclass(frozen=True)
class ImportedSpec:
    text: str
    convention: str
    reason: str | None  # why a simpler convention cannot hold the chain (None: none simpler, or the one asked for)


def _number(value: float, digits: int = 15) -> str:
    return f"{snapped(value):.{digits}g}"


def _pose(T: np.ndarray, fields: tuple[str, ...], fixed: bool = False) -> list[str]:
    """``field: value`` items of a transform in mm and deg (x, y, z, then the ZYX angles), held fixed if ``fixed``."""
    x, y, z, rz, ry, rx = pose_from_matrix(T)
    values = dict(zip(POSE, (x, y, z, *np.rad2deg([rz, ry, rx]))))
    return [f"{field}: " + (f"{{value: {_number(values[key])}, vary: false}}" if fixed else _number(values[key]))
            for field, key in zip(fields, POSE) if field]


def _flow(items: list[str]) -> str:
    return "{" + ", ".join(items) + "}"


def imported_spec(chain: UrdfChain, source: str, base: str, tip: str, convention: str | None = None) -> ImportedSpec:
    """The spec (YAML) of ``chain``, imported from ``source`` between links ``base`` and ``tip``, in ``convention``
    (None: the simplest the chain allows)."""
    if convention is not None and convention not in CONVENTIONS:
        raise UserError(f"unknown convention '{convention}': import-urdf writes {', '.join(CONVENTIONS)}")
    where = str(chain.path or source)
    if convention == "six_parameter":
        return ImportedSpec(_loadable(_text(chain, source, base, tip, None), where), convention, None)
    axes = chain.axes()
    rows = dh_chain(axes, axes[-1] @ chain.links[-1], [j.name for j in chain.joints])
    if convention == "dh" and rows.reason is not None:
        raise UserError(f"{where}: a dh spec cannot hold the chain: {rows.reason} (import it as mdh or six_parameter)")
    chosen = convention or rows.convention
    reason = f"not dh: {rows.reason}" if convention is None and rows.reason is not None else None
    try:
        return ImportedSpec(_loadable(_text(chain, source, base, tip, rows, chosen), where), chosen, reason)
    except UserError as refused:
        if convention is not None:
            raise
        text = _loadable(_text(chain, source, base, tip, None), where)
        return ImportedSpec(text, "six_parameter", f"not {chosen}: {str(refused).removeprefix(where + ': ')}")


def _text(chain: UrdfChain, source: str, base: str, tip: str, rows: DHChain | None, convention: str = "six_parameter") -> str:
    n = len(chain.joints)
    continuous = [j.name for j in chain.joints if j.continuous]
    lines = [f"# {quoted(chain.robot)} imported by armcal import-urdf from {quoted(source)}: the chain from link {quoted(base)} to link {quoted(tip)}."]
    lines += _explained(convention)
    if chain.merged:
        lines.append(f"# Fixed joints merged into the links: {', '.join(quoted(j) for j in chain.merged)}.")
    for master, mimics in chain.mimicked:
        lines.append(f"# Mimic joints {', '.join(quoted(j) for j in mimics)} replaced by the joint they mimic, {quoted(master)}: it moves them all.")
    if continuous:
        lines.append(f"# Continuous joints, given limits of one turn either way (-360, 360 deg): {', '.join(quoted(j) for j in continuous)}.")
    lines += [
        "armcal: 1",
        "robot:",
        f"  name: {quoted(chain.robot)}",
        f"  model: {quoted(chain.robot)}",
        '  serial: "EDIT-ME"  # this very robot\'s serial number, printed on the certificate',
        "  units: {length: mm, angle: deg}",
        f"  convention: {convention}",
    ]
    if rows is None:
        tool, turned = chain.links[-1], [np.eye(4)] * n
        lines += ["  links:", *(f"    - {_flow(_pose(T, LINK))}" for T in chain.links[:-1]),
                  f"    - {{}}  # link {n + 1}: the identity; the tool holds the part after the last joint"]
    else:
        tool, turned = rows.tool, [inverse(F) @ G for F, G in zip(rows.frames, chain.axes())]
        lines.append(f"  base: {_flow(_pose(rows.base, POSE))}")
    lines.append("  joints:")
    for i, joint in enumerate(chain.joints):
        unit_limits = np.rad2deg(joint.limits) if joint.type == "revolute" else np.array(joint.limits)
        items = [f"name: {quoted(joint.name)}", f"type: {joint.type}", f"limits: [{_number(unit_limits[0], 12)}, {_number(unit_limits[1], 12)}]"]
        lines.append(f"    - {_flow(items + _joint(rows, i, convention))}")
    lines += [
        f"  tool: {_flow(_pose(tool, POSE))}  # link {quoted(tip)} on link {n}",
        "  # The URDF's names, and each link's frame in the frame its joint turns (z on the axis): export --format urdf writes them back.",
        "  urdf:",
        f"    base: {quoted(base)}",
        f"    tool: {quoted(tip if tip != chain.joints[-1].link else tip + '_tool')}",  # TIP the last joint's link: the tool is a link of its own
        "    links:",
        *(f"      - {_flow([f'name: {quoted(j.link)}', *_pose(W @ j.frame, LINK_FRAME)])}" for j, W in zip(chain.joints, turned)),
        f"  # A stand-in: the points or frames your instrument measures (here a point {OFF_AXIS:g} mm farther from joint {n}'s axis",
        "  # than the tool's origin: a point on the axis does not see the joint turn, docs/devices/tracker.md).",
        "  targets:",
        f"    {TARGET}: {_flow([f'link: {n}', *_off_axis(tool, turned[-1])])}",
        "# Stand-ins: a spec needs a device and a procedure. These (a laser tracker measuring that point at 100 random",
        "# poses) say nothing about your measurement: see docs/spec.md and the device guides.",
        "device:",
        "  type: tracker",
        f"  targets: [{TARGET}]",
        "  # Where the instrument stands (the robot base in its frame): unknown, identified; the fit starts from a rigid",
        "  # registration of the nominal target positions onto the measured ones (docs/devices/tracker.md).",
        "  robot_base: {x: 0, y: 0, z: 0, rz: 0, ry: 0, rx: 0}",
        "  noise: 0.01  # mm: the instrument's stated noise",
        "procedure:",
        "  type: poses",
        "  count: 100",
    ]
    text = "\n".join(lines) + "\n"
    return text + "\n".join(marker_lines(text, ["robot.serial", "robot.targets", "device", "procedure"])) + "\n"


def _off_axis(tool: np.ndarray, axis: np.ndarray) -> list[str]:
    """``x, y, z`` items (mm, held fixed) of a point OFF_AXIS mm farther than the tool's origin from the last joint's
    axis (the z axis of frame ``axis``, both in the last link's frame), outwards along the radius (along the axis
    frame's x for an origin on the axis)."""
    p, o, d = tool[:3, 3], axis[:3, 3], axis[:3, 2]
    radial = (p - o) - np.dot(p - o, d) * d
    length = np.linalg.norm(radial)
    u = radial / length if length > 1e-9 else axis[:3, 0]
    return [f"{field}: {{value: {_number(v)}, vary: false}}" for field, v in zip("xyz", p + OFF_AXIS * u)]


def _explained(convention: str) -> list[str]:
    """The header comment lines that say what the convention's numbers mean."""
    if convention == "six_parameter":
        return ["# Goswami's six_parameter model (3): link i = Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma) (mm, deg);",
                "# joint i turns about (a prismatic joint slides along) the z axis of the frame before it, theta = theta0 + k q (2),",
                "# here theta0 = 0 and k = 1, fixed. A URDF joint axis other than +z is turned onto z at the end of the link",
                "# before the joint and back at the start of the next; the part after the last joint is the tool."]
    hayati = ["# Hayati's beta (Rot(y, beta) after Rot(x, alpha), d held at 0) where consecutive axes are near parallel."] if convention == "mdh" else []
    return ["# Denavit-Hartenberg, Stone (2.9): A_i = Rot(z, theta + q_i) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha) (mm, deg;",
            "# a prismatic joint adds q_i to d); the base is frame 0 (z on joint 1's axis) in link BASE, the tool link TIP in frame n.",
            *hayati]


def _joint(rows: DHChain | None, i: int, convention: str) -> list[str]:
    """The items of joint i's parameters: theta0 and k fixed (six_parameter), or its DH (MDH) row."""
    if rows is None:
        return ["theta0: {value: 0, vary: false}", "k: {value: 1, vary: false}"]
    row = rows.rows[i]
    items = [f"theta: {_number(np.rad2deg(row.theta))}", f"d: {_number(row.d)}", f"a: {_number(row.a)}", f"alpha: {_number(np.rad2deg(row.alpha))}"]
    if convention == "mdh" and row.parallel:
        items[1] = "d: {value: 0, vary: false}"
        items.append(f"beta: {_number(np.rad2deg(row.beta))}")
    return items


def _loadable(text: str, source: str) -> str:
    """``text``, checked to be a spec file every command reads: within the size of a spec file, and valid."""
    raw, limit = text.encode("utf-8"), INPUT_LIMITS["spec"]
    if len(raw) > limit:
        raise UserError(f"{source}: the chain makes a spec of {len(raw) >> 10} KiB, more than the {limit >> 10} KiB a spec file may have "
                        "(its names are long, or its joints many)")
    try:
        spec_from_bytes(raw, Path(source))
    except SpecError as exc:
        first = exc.issues[0]
        raise UserError(f"{source}: the chain makes no valid spec: {first.field + ': ' if first.field else ''}{first.message}") from None
    return text
