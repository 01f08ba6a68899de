"""The calibrated chain as a DH table (Stone (2.9): Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha),
then Hayati's Rot(y, beta) where the chain has it), with the base and tool transforms, in the spec's units.

A dh or mdh spec's own values are written. Any other chain (six_parameter, s_model) is converted from its joint axes
at q = 0 (kinematics/dh_rows.py): the same forward kinematics, Hayati's beta where consecutive axes are near parallel.
A joint that does not move by its reading (a six_parameter encoder scale k != 1) has no row: the table is refused.
Values have 15 significant digits, so the table moves as the spec does to 1e-9 mm.
"""

from __future__ import annotations

import numpy as np

from armcal.support.errors import UserError
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.dh_rows import dh_chain
from armcal.kinematics.params import parameter_set
from armcal.kinematics.transforms import POSE_FIELDS, pose_from_matrix
from armcal.spec import LoadedSpec
from armcal.support.units import from_internal, snapped

COLUMNS = (("theta", "angle"), ("d", "length"), ("a", "length"), ("alpha", "angle"), ("beta", "angle"))
POSE = (("x", "length"), ("y", "length"), ("z", "length"), ("rz", "angle"), ("ry", "angle"), ("rx", "angle"))


def _values(loaded: LoadedSpec) -> tuple[dict[str, float], str]:
    """Each table entry's value (``joint.column``, ``base.x``, ``tool.rz``: mm, rad) and where the rows come from."""
    robot = loaded.spec.robot
    if robot.convention in ("dh", "mdh"):
        return {e.name: e.nominal for e in parameter_set(robot.chain()).entries}, f"calibrated {robot.convention.upper()} parameters"
    scaled = [f"{name} (k = {joint.k.value:g})" for name, joint in zip(robot.joint_names(), robot.joints)
              if robot.convention == "six_parameter" and joint.k.value != 1.0]
    if scaled:
        raise UserError(f"{loaded.path}: a DH table's joints move by their readings (theta + q); the encoder scale of "
                        f"{', '.join(scaled)} is not 1, so no table holds the chain (export urdf or json)")
    kinematics = compile_robot(robot.chain())
    frames = kinematics.link_frames(np.zeros(kinematics.dof))
    chain = dh_chain(list(frames[:-1]), kinematics.tool_poses(np.zeros((1, kinematics.dof)))[0], list(kinematics.joint_names))
    values = {f"{frame}.{field}": value for frame, T in (("base", chain.base), ("tool", chain.tool))
              for field, value in zip(POSE_FIELDS, pose_from_matrix(T))}
    for name, row in zip(kinematics.joint_names, chain.rows):
        values.update({f"{name}.{column}": getattr(row, column) for column, _ in COLUMNS})
    why = f"; {chain.reason}" if chain.reason else ""
    return values, f"the {robot.convention} chain converted to {chain.convention.upper()} parameters (the same forward kinematics{why})"


def dh_table(loaded: LoadedSpec, effects: tuple[str, ...]) -> str:
    """A plain-text table of the calibrated DH (or MDH) parameters of ``loaded``'s robot."""
    robot = loaded.spec.robot
    value, what = _values(loaded)
    shown = lambda name, kind: f"{snapped(from_internal(value.get(name, 0.0), kind, robot.units.of(kind))):.15g}"  # noqa: E731
    unit = lambda kind: robot.units.of(kind)  # noqa: E731
    lines = [
        f"# {robot.name}, serial {robot.serial}: {what} (armcal, from {loaded.path.name})",
        "# A_i = Rot(z, theta + q_i) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha) Rot(y, beta)   (Stone (2.9); beta: Hayati)",
        "# prismatic joints: d + q_i. Chain: base * A_1 ... A_n * tool.",
        "joint\ttype\t" + "\t".join(f"{c} ({unit(k)})" for c, k in COLUMNS),
    ]
    for name, joint in zip(robot.joint_names(), robot.joints):
        lines.append(f"{name}\t{joint.type}\t" + "\t".join(shown(f"{name}.{c}", k) for c, k in COLUMNS))
    for frame in ("base", "tool"):
        lines.append(f"# {frame}: " + ", ".join(f"{c} {shown(f'{frame}.{c}', k)} {unit(k)}" for c, k in POSE))
    if effects:
        lines.append("# Not held by a DH table (armcal's calibrated.yaml keeps them): " + ", ".join(effects))
    return "\n".join(lines) + "\n"
