"""The calibrated chain as the kinematics file of Universal Robots' ROS driver (ur_description's
``kinematics_params_file``, as ur_calibration writes it).

ur_description builds the arm from six joint origins, each ``x, y, z`` (m) and ``roll, pitch, yaw``
(rad, R = Rz(yaw) Ry(pitch) Rx(roll)) relative to the previous link, every axis z; the chain starts
at ``base_link_inertia`` (the controller's base, the DH base frame) and ``tool0`` is the
``wrist_3_link`` frame. A DH chain (Stone (2.9), with Hayati's Rot(y, beta)) regroups exactly into
that form: joint i's origin is Trans(a, 0, 0) Rot(x, alpha) Rot(y, beta) of joint i-1 followed by
Trans(0, 0, d) Rot(z, theta) of joint i, so each link frame sits on its joint's axis where UR's
meshes expect it, and what follows joint 6 (its a, alpha, beta and the tool) is the flange's offset
from ``tool0``. What the file cannot hold is returned: the robot's mounting (a calibrated
``robot.base``), a flange offset, a tool, and the effects.
"""

from __future__ import annotations

import hashlib

import numpy as np

from armcal.support.errors import UserError
from armcal.kinematics.params import parameter_set
from armcal.kinematics.transforms import compose, pose_from_matrix, rot_x, rot_y, rot_z, trans, xyz_zyx
from armcal.spec import LoadedSpec

SEGMENTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")  # ur_description's names, joint 1..6
IDENTITY = 1e-12  # mm and rotation entries: a transform closer than this to the identity is none


def _line(name: str, T: np.ndarray) -> list[str]:
    x, y, z, yaw, pitch, roll = pose_from_matrix(T)
    values = {"x": x / 1000.0, "y": y / 1000.0, "z": z / 1000.0, "roll": roll, "pitch": pitch, "yaw": yaw}
    return [f"  {name}:"] + [f"    {key}: {value + 0.0!r}" for key, value in values.items()]


def _is_identity(T: np.ndarray) -> bool:
    return bool(np.max(np.abs(T - np.eye(4))) < IDENTITY)


def ur_calibration(loaded: LoadedSpec, effects: tuple[str, ...]) -> tuple[str, tuple[str, ...]]:
    """YAML text of the six joint origins (metres, radians) and what the file cannot hold."""
    robot = loaded.spec.robot
    if robot.convention not in ("dh", "mdh") or robot.dof != 6 or any(j.type != "revolute" for j in robot.joints):
        raise UserError(
            f"{loaded.path}: the UR driver's kinematics file holds six revolute joints of a DH chain; "
            f"this robot is {robot.convention} with {robot.dof} joints (export urdf instead)"
        )
    entries = parameter_set(robot.chain()).entries
    value = {e.name: e.nominal for e in entries}
    at = lambda joint, field: value.get(f"{joint}.{field}", 0.0)  # noqa: E731
    names = robot.joint_names()
    after = [compose(trans(at(j, "a"), 0, 0), rot_x(at(j, "alpha")), rot_y(at(j, "beta"))) for j in names]
    before = [compose(trans(0, 0, at(j, "d")), rot_z(at(j, "theta"))) for j in names]
    origins = [before[0]] + [after[i - 1] @ before[i] for i in range(1, 6)]
    pose = lambda frame: xyz_zyx(*(value[f"{frame}.{c}"] for c in ("x", "y", "z", "rz", "ry", "rx")))  # noqa: E731
    flange = after[5] @ pose("tool")
    left_out = list(effects)
    if any(e.name.startswith("base.") and e.free for e in entries):
        x, y, z, rz, ry, rx = pose_from_matrix(pose("base"))
        left_out.append(
            f"the robot's mounting (robot.base: x {x:.6g}, y {y:.6g}, z {z:.6g} mm, rz {np.degrees(rz):.6g}, "
            f"ry {np.degrees(ry):.6g}, rx {np.degrees(rx):.6g} deg; the joint to base_link in your workcell's URDF)"
        )
    if not _is_identity(flange):
        x, y, z, rz, ry, rx = pose_from_matrix(flange)
        left_out.append(
            f"the tool's offset from tool0 (x {x:.6g}, y {y:.6g}, z {z:.6g} mm, rz {np.degrees(rz):.6g}, "
            f"ry {np.degrees(ry):.6g}, rx {np.degrees(rx):.6g} deg: the TCP on the teach pendant)"
        )
    lines = []
    for name, T in zip(SEGMENTS, origins):
        lines += _line(name, T)
    digest = hashlib.sha256("\n".join(lines).encode()).hexdigest()[:20]
    header = [
        f"# {robot.name}, serial {robot.serial}: calibrated kinematics for Universal Robots' ROS driver, written by armcal",
        f"# from {loaded.path.name}. Pass it as kinematics_params_file (ur_robot_driver's launch argument).",
        "# Joint origins in m and rad (ur_description: xyz, then rpy R = Rz(yaw) Ry(pitch) Rx(roll)), from base_link_inertia.",
        "# The hash is armcal's, not the controller's: the driver warns that it differs from the robot's factory calibration.",
    ]
    if left_out:
        header.append("# Not held by this file (armcal's calibrated.yaml keeps them): " + "; ".join(left_out))
    text = "\n".join([*header, "kinematics:", *lines, f"  hash: armcal_{digest}"]) + "\n"
    return text, tuple(left_out)
