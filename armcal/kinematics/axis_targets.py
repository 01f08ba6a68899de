"""Targets on the axis of the joint they ride on.

A point on a revolute joint's axis does not move when that joint turns, so a device that reads the point's position
learns nothing of the joint from it (docs/devices/tracker.md: one reflector on the PUMA's joint-6 axis identifies 30 of
its 36 robot parameters, off the axis 33). Joint i turns about the z axis of frame F_(i-1) (kinematics/compiler.py);
a target on link i is fixed in F_i, so its distance from that axis is the same at every configuration.
"""

from __future__ import annotations

import numpy as np

from armcal.kinematics.chain import DeclaredChain
from armcal.kinematics.compiler import compile_robot

ON_AXIS = 1.0  # mm: a target nearer its joint's axis than this moves less than 1 mm per radian of the joint


def targets_on_axes(chain: DeclaredChain, orientation_read: bool) -> list[tuple[str, int, float]]:
    """(target, joint (1-based), distance in mm) of each target of ``chain`` within ON_AXIS of the axis of the revolute
    joint whose link carries it; a frame whose orientation the device reads (``orientation_read``) sees the joint
    turn, and is not listed."""
    kinematics = compile_robot(chain)
    q = np.zeros(kinematics.dof)
    frames = kinematics.link_frames(q)
    found = []
    for name, link in kinematics.target_links.items():
        if link == 0 or kinematics.joint_types[link - 1] != "revolute":
            continue
        if chain.targets[name].is_frame and orientation_read:
            continue
        axis = frames[link - 1]
        offset = kinematics.target_poses(name, q[None])[0, :3, 3] - axis[:3, 3]
        distance = float(np.linalg.norm(offset - (offset @ axis[:3, 2]) * axis[:3, 2]))
        if distance < ON_AXIS:
            found.append((name, link, distance))
    return found
