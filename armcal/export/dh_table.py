"""The calibrated chain as a DH table (Stone (2.9): Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha),
then Hayati's Rot(y, beta) where the chain has it), with the base and tool transforms, in the spec's units."""

from __future__ import annotations

from armcal.errors import UserError
from armcal.kinematics.params import parameter_set
from armcal.spec import LoadedSpec
from armcal.units import from_internal

COLUMNS = (("theta", "angle"), ("d", "length"), ("a", "length"), ("alpha", "angle"), ("beta", "angle"))
POSE = (("x", "length"), ("y", "length"), ("z", "length"), ("rz", "angle"), ("ry", "angle"), ("rx", "angle"))


def dh_table(loaded: LoadedSpec, effects: tuple[str, ...]) -> str:
    """A plain-text table of the calibrated DH (or MDH) parameters of ``loaded``'s robot."""
    robot = loaded.spec.robot
    if robot.convention not in ("dh", "mdh"):
        raise UserError(f"{loaded.path}: the chain is {robot.convention}; a DH table cannot hold it (export urdf or json)")
    parameters = parameter_set(robot)
    value = {e.name: e.nominal for e in parameters.entries}
    shown = lambda name, kind: f"{from_internal(value.get(name, 0.0), kind, robot.units.of(kind)):.9g}"  # noqa: E731
    unit = lambda kind: robot.units.of(kind)  # noqa: E731
    lines = [
        f"# {robot.name}, serial {robot.serial}: calibrated {robot.convention.upper()} parameters (armcal, from {loaded.path.name})",
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
