"""Independent oracle for the robot library: the joint origins of each robot's URDF, typed in from
the ROS-Industrial (and maker's) description packages, and their forward kinematics in plain numpy.

A URDF joint places its child frame at Trans(xyz) Rot(z, yaw) Rot(y, pitch) Rot(x, roll) in its
parent and turns it about ``axis`` by the joint position; fixed joints add the flange ("tool0").
Lengths are metres and angles radians, as in the files. Joint positions are the URDF's own, which
the ROS drivers pass to and from the controllers unchanged (Fanuc: see FANUC_J23 below).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import pi, radians

import numpy as np


@dataclass(frozen=True)
class Joint:
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] | None = None  # None: a fixed joint


@dataclass(frozen=True)
class Chain:
    source: str  # repository and file the numbers were typed from
    joints: tuple[Joint, ...]  # the movable joints, then the fixed ones up to tool0

    @property
    def dof(self) -> int:
        return sum(j.axis is not None for j in self.joints)


def _rotation(axis, angle: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _origin(joint: Joint) -> np.ndarray:
    roll, pitch, yaw = joint.rpy
    T = np.eye(4)
    T[:3, :3] = _rotation((0, 0, 1), yaw) @ _rotation((0, 1, 0), pitch) @ _rotation((1, 0, 0), roll)
    T[:3, 3] = joint.xyz
    return T


def urdf_flange_pose(chain: Chain, q) -> np.ndarray:
    """Pose of tool0 in the chain's root frame, metres, at joint positions q (rad)."""
    T, values = np.eye(4), iter(q)
    for joint in chain.joints:
        T = T @ _origin(joint)
        if joint.axis is not None:
            R = np.eye(4)
            R[:3, :3] = _rotation(joint.axis, next(values))
            T = T @ R
    return T


def _ur(d1: float, a2: float, a3: float, d4: float, d5: float, d6: float, source: str) -> Chain:
    """UR's calibration-format kinematics (default_kinematics.yaml): shoulder .. wrist_3 origins,
    every joint about its z; the roll values are the files' own 9-digit pi/2 (their z residues of
    2e-11 m are left out). wrist_3 -> flange ->
    tool0 is Rot(rpy 0, -pi/2, -pi/2) Rot(rpy pi/2, 0, pi/2) (ur_macro.xacro), the identity."""
    z = (0.0, 0.0, 1.0)
    return Chain(
        source,
        (
            Joint((0, 0, d1), (0, 0, 0), z),
            Joint((0, 0, 0), (1.570796327, 0, 0), z),
            Joint((a2, 0, 0), (0, 0, 0), z),
            Joint((a3, 0, d4), (0, 0, 0), z),
            Joint((0, -d5, 0), (1.570796327, 0, 0), z),
            Joint((0, d6, 0), (1.570796326589793, pi, pi), z),
            Joint((0, 0, 0), (0, -pi / 2, -pi / 2)),
            Joint((0, 0, 0), (pi / 2, 0, pi / 2)),
        ),
    )


X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
MX, MY, MZ = (-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)
TOOL0_ABOUT_Y = Joint((0, 0, 0), (0, pi / 2, 0))  # ROS-Industrial tool0: z out of the flange
FANUC_TOOL0 = Joint((0, 0, 0), (pi, -pi / 2, 0))

# Fanuc's controller reports J3 against the horizon (the J2/J3 interaction); the URDF's joint_3 is
# the relative angle, which the ROS-Industrial fanuc driver computes as J3 + J2. The library (and
# this oracle) use the URDF's relative joint 3.
FANUC_J23 = "joint 3 is the relative angle J2 + J3 of Fanuc's controller"

CHAINS: dict[str, Chain] = {
    "ur3e": _ur(0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921, "ros-industrial/universal_robot ur_description/config/ur3e/default_kinematics.yaml"),
    "ur5e": _ur(0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996, "ros-industrial/universal_robot ur_description/config/ur5e/default_kinematics.yaml"),
    "ur10e": _ur(0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655, "ros-industrial/universal_robot ur_e_description/config/ur10e_default.yaml"),
    "ur16e": _ur(0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655, "ros-industrial/universal_robot ur_description/config/ur16e/default_kinematics.yaml"),
    "kuka_kr6_r900_sixx": Chain(
        "ros-industrial/kuka_experimental kuka_kr6_support/urdf/kr6r900sixx_macro.xacro",
        (
            Joint((0, 0, 0.400), axis=MZ),
            Joint((0.025, 0, 0), axis=Y),
            Joint((0.455, 0, 0), axis=Y),
            Joint((0, 0, 0.035), axis=MX),
            Joint((0.420, 0, 0), axis=Y),
            Joint((0.080, 0, 0), axis=MX),
            TOOL0_ABOUT_Y,
        ),
    ),
    "kuka_kr16_2": Chain(
        "ros-industrial/kuka_experimental kuka_kr16_support/urdf/kr16_2_macro.xacro",
        (
            Joint((0, 0, 0.675), axis=MZ),
            Joint((0.26, 0, 0), axis=Y),
            Joint((0.68, 0, 0), axis=Y),
            Joint((0.67, 0, -0.035), axis=MX),
            Joint((0, 0, 0), axis=Y),
            Joint((0, 0, 0), axis=MX),
            Joint((0.158, 0, 0), (0, pi / 2, 0)),
        ),
    ),
    "kuka_kr210_r2700_extra": Chain(
        "ros-industrial/kuka_experimental kuka_kr210_support/urdf/kr210r2700extra_macro.xacro",
        (
            Joint((0, 0, 0.675), axis=MZ),
            Joint((0.350, 0, 0), axis=Y),
            Joint((1.150, 0, 0), axis=Y),
            Joint((0, 0, -0.041), axis=MX),
            Joint((1.200, 0, 0), axis=Y),
            Joint((0.215, 0, 0), axis=MX),
            TOOL0_ABOUT_Y,
        ),
    ),
    "abb_irb120": Chain(
        "ros-industrial/abb abb_irb120_support/urdf/irb120_3_58_macro.xacro",
        (
            Joint((0, 0, 0), axis=Z),
            Joint((0, 0, 0.29), axis=Y),
            Joint((0, 0, 0.27), axis=Y),
            Joint((0, 0, 0.07), axis=X),
            Joint((0.302, 0, 0), axis=Y),
            Joint((0.072, 0, 0), axis=X),
            TOOL0_ABOUT_Y,
        ),
    ),
    "abb_irb1600": Chain(
        "ros-industrial/abb_experimental abb_irb1600_support/urdf/irb1600_8_145_macro.xacro",
        (
            Joint((0, 0, 0), axis=Z),
            Joint((0.15, 0, 0.4865), axis=Y),
            Joint((0, 0, 0.700), axis=Y),
            Joint((0.300, 0, 0), axis=X),
            Joint((0.300, 0, 0), axis=Y),
            Joint((0.065, 0, 0), axis=X),
            TOOL0_ABOUT_Y,
        ),
    ),
    "abb_irb6700": Chain(
        "ros-industrial/abb_experimental abb_irb6700_support/urdf/irb6700_235_265_macro.xacro",
        (
            Joint((0, 0, 0.288), axis=Z),
            Joint((0.32, 0, 0.492), axis=Y),
            Joint((0, 0, 1.135), axis=Y),
            Joint((0, 0, 0.2), axis=X),
            Joint((1.1825, 0, 0), axis=Y),
            Joint((0.165, 0, 0), axis=X),
            Joint((0.035, 0, 0), (0, pi / 2, 0)),
        ),
    ),
    "fanuc_lrmate200id": Chain(
        "ros-industrial/fanuc fanuc_lrmate200id_support/urdf/lrmate200id_macro.xacro",
        (
            Joint((0, 0, 0.330), axis=Z),
            Joint((0.050, 0, 0), axis=Y),
            Joint((0, 0, 0.330), axis=MY),
            Joint((0, 0, 0.035), axis=MX),
            Joint((0.335, 0, 0), axis=MY),
            Joint((0.080, 0, 0), axis=MX),
            FANUC_TOOL0,
        ),
    ),
    "fanuc_m20ia": Chain(
        "ros-industrial/fanuc fanuc_m20ia_support/urdf/m20ia_macro.xacro",
        (
            Joint((0, 0, 0.525), axis=Z),
            Joint((0.150, 0, 0), axis=Y),
            Joint((0, 0, 0.790), axis=MY),
            Joint((0, 0, 0.250), axis=MX),
            Joint((0.835, 0, 0), axis=MY),
            Joint((0.100, 0, 0), axis=MX),
            FANUC_TOOL0,
        ),
    ),
    "staubli_tx2_60": Chain(
        "ros-industrial/staubli_experimental staubli_tx2_60_support/urdf/tx2_60_macro.xacro",
        (
            Joint((0, 0, 0.375), axis=Z),
            Joint((0, 0, 0), axis=Y),
            Joint((0, 0.02, 0.29), axis=Y),
            Joint((0, 0, 0), axis=Z),
            Joint((0, 0, 0.31), axis=Y),
            Joint((0, 0, 0.07), axis=Z),
            Joint((0, 0, 0), (0, radians(-90), 0)),  # link_6 -> flange
            Joint((0, 0, 0), (0, radians(90), 0)),  # flange -> tool0
        ),
    ),
    "franka_panda": Chain(
        "frankaemika/franka_ros franka_description/robots/panda_arm.xacro",
        (
            Joint((0, 0, 0.333), (0, 0, 0), Z),
            Joint((0, 0, 0), (-pi / 2, 0, 0), Z),
            Joint((0, -0.316, 0), (pi / 2, 0, 0), Z),
            Joint((0.0825, 0, 0), (pi / 2, 0, 0), Z),
            Joint((-0.0825, 0.384, 0), (-pi / 2, 0, 0), Z),
            Joint((0, 0, 0), (pi / 2, 0, 0), Z),
            Joint((0.088, 0, 0), (pi / 2, 0, 0), Z),
            Joint((0, 0, 0.107)),  # joint8: link7 -> link8, the flange
        ),
    ),
}
