"""Stone's circle-point procedure (4.5, 6.4, Fig. 6-7): one circle per joint, swept at the signature.

Target i rides on link i; joint i is swept through N_i positions uniformly over
its limits while every other joint stays at the signature configuration
(joints i+1..n do not move target i; holding them keeps the lines of sight as at
the signature). Targets are measured in Stone's order 6, 5, ..., 1. Positions
where the target is not visible to the instrument are dropped.
"""

from __future__ import annotations

import numpy as np

from armcal.devices.base import DeviceModel
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures.plan import Plan, sweep
from armcal.spec.procedure import CirclePoint


def plan_circle_point(procedure: CirclePoint, kinematics: KinematicModel, device: DeviceModel) -> Plan:
    counts = procedure.points_per_joint
    counts = counts if isinstance(counts, list) else [counts] * kinematics.dof
    signature = np.asarray(procedure.signature, dtype=float)
    plans = []
    for i in reversed(range(kinematics.dof)):
        low, high = kinematics.limits[i]
        values = sweep(low, high, counts[i], kinematics.joint_types[i] == "revolute")
        Q = np.tile(signature, (len(values), 1))
        Q[:, i] = values
        key = (procedure.targets[i],)
        visible = device.visible(key, kinematics.target_poses(key[0], Q))
        dropped = {f"{key[0]} not visible": int((~visible).sum())} if (~visible).any() else {}
        plans.append(Plan(tuple([key] * int(visible.sum())), Q[visible], dropped))
    return Plan.join(plans)
