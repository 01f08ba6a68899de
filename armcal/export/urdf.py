"""The calibrated chain as URDF: one joint per axis, its origin and axis, fixed links for the tool and targets.

armcal's chain is F_0 = base, F_i = F_(i-1) A_i(q_i), the axis of joint i the z axis of
F_(i-1) through its origin (docs/spec.md). URDF's link i is the frame F_(i-1) Rot(z, q_i)
(Trans(0, 0, q_i) for a prismatic joint): joint i's origin is then the fixed part
D_(i-1) = F_(i-2)^-1 F_(i-1) at q = 0 (for joint 1: F_0, the base in the world), its axis
z. The motion is checked at random configurations; a joint that does not move as Rot(z, q)
about F_(i-1) (a six_parameter encoder scale k != 1) cannot be held and is named.
A spec with ``robot.urdf`` (import-urdf writes it) keeps the URDF's names and link frames: link i is then
F_(i-1) Rot(z, q_i) W_i, W_i = Trans(0, 0, z) Rot(z, rz) Rot(y, ry) Rot(x, rx) its frame in the turning frame, so
joint i's origin is W_(i-1)^-1 D_(i-1) W_i and its axis W_i^-1 z (W_i^-1 Rot(z, q) W_i = Rot(W_i^-1 z, q), W_i's
origin on the axis). Without it the links are world, link_1 .. link_n and tool0, W_i the identity.
URDF lengths are metres, angles radians, rpy the fixed-axis roll-pitch-yaw of
R = Rz(yaw) Ry(pitch) Rx(roll).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import compose, pose_from_matrix, rot_x, rot_y, rot_z, trans
from armcal.spec.document import Spec
from armcal.spec_parts.robot import RobotBase

CHECKS = 20  # random configurations at which the URDF's motion is compared with the chain's
TOLERANCE = 1e-9  # mm (and unit rotation entries): a joint moving otherwise is not Rot(z, q) about F_(i-1)


def _origin(T: np.ndarray) -> str:
    x, y, z, rz, ry, rx = pose_from_matrix(T)
    return f'<origin xyz="{x / 1000 + 0.0:.12g} {y / 1000 + 0.0:.12g} {z / 1000 + 0.0:.12g}" rpy="{rx + 0.0:.15g} {ry + 0.0:.15g} {rz + 0.0:.15g}"/>'


def _motion(kind: str, value: float) -> np.ndarray:
    M = np.eye(4)
    if kind == "prismatic":
        M[2, 3] = value
    else:
        c, s = np.cos(value), np.sin(value)
        M[:2, :2] = [[c, -s], [s, c]]
    return M


def _joints_not_held(kinematics: KinematicModel, fixed: list[np.ndarray]) -> list[str]:
    """The joints whose motion is not Rot(z, q) (Trans(z, q)) about F_(i-1) followed by the fixed D_i."""
    rng = np.random.default_rng(0)
    low, high = kinematics.limits[:, 0], kinematics.limits[:, 1]
    bad = set()
    for q in rng.uniform(low, high, (CHECKS, kinematics.dof)):
        F = kinematics.link_frames(q)
        for i, kind in enumerate(kinematics.joint_types):
            predicted = F[i] @ _motion(kind, q[i]) @ fixed[i + 1]
            if np.max(np.abs(predicted - F[i + 1])) > TOLERANCE * max(1.0, np.max(np.abs(F[i + 1]))):
                bad.add(i)
    return [kinematics.joint_names[i] for i in sorted(bad)]


def _link_frames(robot: RobotBase) -> list[np.ndarray]:
    """W_0 .. W_n: each link's frame in the frame its joint turns (robot.urdf's, else the identity), W_0 the world's."""
    links = robot.urdf.links if robot.urdf else []
    return [np.eye(4)] + ([compose(trans(0, 0, w.z), rot_z(w.rz), rot_y(w.ry), rot_x(w.rx)) for w in links] or [np.eye(4)] * robot.dof)


def urdf(spec: Spec, kinematics: KinematicModel, effects: tuple[str, ...]) -> tuple[str, tuple[str, ...]]:
    """URDF text of the calibrated chain and the joints it cannot hold (their scale)."""
    F0 = kinematics.link_frames(np.zeros(kinematics.dof))
    fixed = [F0[0]] + [np.linalg.inv(F0[i - 1]) @ F0[i] for i in range(1, kinematics.dof + 1)]
    not_held = _joints_not_held(kinematics, fixed)
    tool = np.linalg.inv(F0[-1]) @ kinematics.tool_poses(np.zeros((1, kinematics.dof)))[0]
    name = spec.robot.model or spec.robot.name
    lines = [
        '<?xml version="1.0"?>',
        (f"<!-- {spec.robot.name}, serial {spec.robot.serial}: calibrated kinematics exported by armcal."
         " Lengths in m, angles in rad; joint limits from the spec, effort and velocity unknown to armcal (0). -->"),
    ]
    if effects or not_held:
        lines.append("<!-- Not held by this URDF (armcal's calibrated.yaml keeps them): "
                     + ", ".join([*effects, *(f"encoder scale of {j}" for j in not_held)]) + " -->")
    names, W = spec.robot.link_names(), _link_frames(spec.robot)
    lines += [f"<robot name={quoteattr(name)}>", f"  <link name={quoteattr(names[0])}/>"]
    for i, (joint, kind) in enumerate(zip(kinematics.joint_names, kinematics.joint_types), start=1):
        low, high = kinematics.limits[i - 1] / (1000.0 if kind == "prismatic" else 1.0)
        axis = W[i][:3, :3].T[:, 2]
        lines += [
            f"  <link name={quoteattr(names[i])}/>",
            f"  <joint name={quoteattr(joint)} type=\"{kind}\">",
            f"    <parent link={quoteattr(names[i - 1])}/>",
            f"    <child link={quoteattr(names[i])}/>",
            f"    {_origin(np.linalg.inv(W[i - 1]) @ fixed[i - 1] @ W[i])}",
            f'    <axis xyz="{" ".join(f"{v + 0.0:.15g}" for v in axis)}"/>',
            f'    <limit lower="{low:.12g}" upper="{high:.12g}" effort="0" velocity="0"/>',
            "  </joint>",
        ]
    frames = {names[-1]: (kinematics.dof, fixed[-1] @ tool)}
    for target, link in kinematics.target_links.items():
        on_link = np.linalg.inv(F0[link]) @ kinematics.target_poses(target, np.zeros((1, kinematics.dof)))[0]
        frames[target] = (link, (fixed[link] if link else F0[0]) @ on_link)
    for frame, (link, T) in frames.items():
        lines += [
            f"  <link name={quoteattr(frame)}/>",
            f"  <joint name={quoteattr(frame + '_fixed')} type=\"fixed\">",
            f"    <parent link={quoteattr(names[link])}/>",
            f"    <child link={quoteattr(frame)}/>",
            f"    {_origin(np.linalg.inv(W[link]) @ T)}",
            "  </joint>",
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n", tuple(f"encoder scale of {j}" for j in not_held)
