"""A URDF chain as a spec in Goswami's six_parameter model, with stand-ins (its placeholders) for the serial, target, device and procedure.

Goswami's chain T = T1L T1J T2L ... TnJ T(n+1)L (3), each link Trans(x, y, z) Rot(z, alpha) Rot(y, beta)
Rot(x, gamma), each joint Rot(z, theta) (Trans(0, 0, theta) when prismatic), theta = theta0 + k q (2): the
chain's links[i - 1] is link i, its last fixed transform the spec's tool (link n + 1 left at the identity),
theta0 = 0 and k = 1 fixed. Values in mm and deg with 15 significant digits (limits 12; below 1e-12, 0), so
the spec's forward kinematics is the URDF's to 1e-9 mm. The text is checked as ``armcal validate`` checks the file:
within a spec file's size and valid (a chain whose links add up beyond what armcal computes with is refused here, not
written).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from armcal.errors import SpecError, UserError
from armcal.fileio import INPUT_LIMITS
from armcal.importers.urdf import UrdfChain
from armcal.kinematics.transforms import pose_from_matrix
from armcal.spec.loader import spec_from_bytes
from armcal.spec.placeholders import marker_lines
from armcal.units import snapped

LINK = ("x", "y", "z", "alpha", "beta", "gamma")  # Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma)
TOOL = ("x", "y", "z", "rz", "ry", "rx")  # Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx): the same product
TARGET = "tool_point"
OFF_AXIS = 50.0  # mm: the stand-in target's distance from the last joint's axis beyond the tool's origin (the tracker guide's reflector)


def _number(value: float, digits: int = 15) -> str:
    return f"{snapped(value):.{digits}g}"


def _pose(T: np.ndarray, fields: tuple[str, ...]) -> list[str]:
    """``field: value`` items of a transform in mm and deg (x, y, z, then the ZYX angles)."""
    x, y, z, rz, ry, rx = pose_from_matrix(T)
    values = (x, y, z, *np.rad2deg([rz, ry, rx]))
    return [f"{field}: {_number(v)}" for field, v in zip(fields, values)]


def _flow(items: list[str]) -> str:
    return "{" + ", ".join(items) + "}"


def six_parameter_spec(chain: UrdfChain, source: str, base: str, tip: str) -> str:
    """The text of a spec (YAML) whose robot is ``chain``, imported from ``source`` between links ``base`` and ``tip``."""
    n = len(chain.joints)
    quoted = json.dumps  # a JSON string is a YAML string: names and paths are written as data, whatever they hold
    continuous = [j.name for j in chain.joints if j.continuous]
    lines = [
        f"# {quoted(chain.robot)} imported by armcal import-urdf from {quoted(source)}: the chain from link {quoted(base)} to link {quoted(tip)}.",
        "# Goswami's six_parameter model (3): link i = Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma) (mm, deg);",
        "# joint i turns about (a prismatic joint slides along) the z axis of the frame before it, theta = theta0 + k q (2),",
        "# here theta0 = 0 and k = 1, fixed. A URDF joint axis other than +z is turned onto z at the end of the link",
        "# before the joint and back at the start of the next; the part after the last joint is the tool.",
    ]
    if chain.merged:
        lines.append(f"# Fixed joints merged into the links: {', '.join(quoted(j) for j in chain.merged)}.")
    if continuous:
        lines.append(f"# Continuous joints, given limits of one turn either way (-360, 360 deg): {', '.join(quoted(j) for j in continuous)}.")
    lines += [
        "armcal: 1",
        "robot:",
        f"  name: {quoted(chain.robot)}",
        f"  model: {quoted(chain.robot)}",
        '  serial: "EDIT-ME"  # this very robot\'s serial number, printed on the certificate',
        "  units: {length: mm, angle: deg}",
        "  convention: six_parameter",
        "  links:",
        *(f"    - {_flow(_pose(T, LINK))}" for T in chain.links[:-1]),
        f"    - {{}}  # link {n + 1}: the identity; the tool holds the part after the last joint",
        "  joints:",
    ]
    for joint in chain.joints:
        unit_limits = np.rad2deg(joint.limits) if joint.type == "revolute" else np.array(joint.limits)
        lines.append(f"    - {{name: {quoted(joint.name)}, type: {joint.type}, limits: [{_number(unit_limits[0], 12)}, {_number(unit_limits[1], 12)}],"
                     " theta0: {value: 0, vary: false}, k: {value: 1, vary: false}}")
    lines += [
        f"  tool: {_flow(_pose(chain.links[-1], TOOL))}  # link {quoted(tip)} on link {n}",
        f"  # A stand-in: the points or frames your instrument measures (here a point {OFF_AXIS:g} mm farther from joint {n}'s axis",
        "  # than the tool's origin: a point on the axis does not see the joint turn, docs/devices/tracker.md).",
        "  targets:",
        f"    {TARGET}: {_flow([f'link: {n}', *_off_axis(chain.links[-1])])}",
        "# Stand-ins: a spec needs a device and a procedure. These (a laser tracker measuring that point at 100 random",
        "# poses) say nothing about your measurement: see docs/spec.md and the device guides.",
        "device:",
        "  type: tracker",
        f"  targets: [{TARGET}]",
        "  noise: 0.01  # mm: the instrument's stated noise",
        "procedure:",
        "  type: poses",
        "  count: 100",
    ]
    text = "\n".join(lines) + "\n"
    text += "\n".join(marker_lines(text, ["robot.serial", "robot.targets", "device", "procedure"])) + "\n"
    return _loadable(text, str(chain.path or source))


def _off_axis(tool: np.ndarray) -> list[str]:
    """``x, y, z`` items (mm, held fixed) of a point OFF_AXIS mm farther from the last joint's axis (z of the last link's
    frame) than the tool's origin, outwards along the radius (along x for an origin on the axis)."""
    x, y, z = tool[:3, 3]
    radius = np.hypot(x, y)
    ux, uy = (x / radius, y / radius) if radius > 1e-9 else (1.0, 0.0)
    return [f"{field}: {{value: {_number(v)}, vary: false}}" for field, v in zip("xyz", (x + OFF_AXIS * ux, y + OFF_AXIS * uy, z))]


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
