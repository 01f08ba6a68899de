"""Pose lists: random configurations within the joint limits, or joint values from a CSV file.

Every pose is measured on every key the instrument reads at a pose
(DeviceModel.pose_keys: each tracker target; each theodolite station and
target); keys where the instrument cannot read the target are dropped; what it
reads with no robot pose is added (fixed_samples: a theodolite's scale-bar
marks). An instrument that reads each pose on one key (keyed_poses: a ball-bar)
takes its poses from a file that names the key of each (``armcal plan`` writes
one); a pose it cannot read (a length outside the LVDT travel) is dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armcal.dataio.reader import read_pose_file
from armcal.devices.base import DeviceModel, Key
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures.plan import Plan
from armcal.spec.document import Spec
from armcal.spec.procedure import Poses

def plan_poses(procedure: Poses, kinematics: KinematicModel, device: DeviceModel, spec: Spec, spec_dir: Path) -> Plan:
    if procedure.file is not None:
        Q, file_keys = read_pose_file(spec_dir / procedure.file, spec)
        if file_keys is not None:
            return keyed_plan(Q, file_keys, kinematics, device)
    elif device.keyed_poses:
        return random_keyed_plan(spec, kinematics, device, procedure.count, np.random.default_rng(procedure.seed))
    else:
        rng = np.random.default_rng(procedure.seed)
        Q = rng.uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (procedure.count, kinematics.dof))
    keys: list[Key] = []
    rows: list[np.ndarray] = []
    dropped: dict[str, int] = {}
    for key in device.pose_keys():
        visible = device.visible(key, kinematics.target_poses(device.target(key), Q))
        keys += [key] * int(visible.sum())
        rows.append(Q[visible])
        if (~visible).any():
            dropped[f"{'/'.join(key)} not visible"] = int((~visible).sum())
    plan = Plan(tuple(keys), np.concatenate(rows), dropped)
    fixed = fixed_samples(device, kinematics.dof)
    return plan if fixed is None else Plan.join([plan, fixed])


def fixed_samples(device: DeviceModel, dof: int) -> Plan | None:
    """What the instrument reads with no robot pose (a theodolite's scale-bar marks); None if nothing."""
    keys = device.fixed_samples()
    return Plan(tuple(keys), np.zeros((len(keys), dof))) if keys else None


def random_keyed_plan(spec: Spec, kinematics: KinematicModel, device: DeviceModel, count: int, rng: np.random.Generator) -> Plan:
    """``count`` random poses of an instrument that reads each pose on one key, as it draws and solves them; those
    the nominal robot cannot reach or the instrument cannot read dropped."""
    Q, keys, dropped = device.random_keyed_poses(spec, kinematics, count, rng)
    reached = ~np.isnan(Q).any(axis=1)
    plan = keyed_plan(Q[reached], tuple(k for k, r in zip(keys, reached) if r), kinematics, device)
    unreached = {"unreachable within the joint limits": int((~reached).sum())} if (~reached).any() else {}
    return Plan(plan.keys, plan.q, {**dropped, **unreached, **plan.dropped})


def keyed_plan(Q: np.ndarray, keys: tuple[Key, ...], kinematics: KinematicModel, device: DeviceModel) -> Plan:
    """Poses each read with its own key (a ball-bar's pose file), in their order; those it cannot read dropped."""
    keep = np.zeros(len(Q), dtype=bool)
    dropped: dict[str, int] = {}
    for key in dict.fromkeys(keys):
        rows = np.flatnonzero([k == key for k in keys])
        keep[rows] = device.visible(key, kinematics.target_poses(device.target(key), Q[rows]))
        if not keep[rows].all():
            dropped[f"{'-'.join(k for k in key if k)} not readable"] = int((~keep[rows]).sum())
    return Plan(tuple(k for k, ok in zip(keys, keep) if ok), Q[keep], dropped)
