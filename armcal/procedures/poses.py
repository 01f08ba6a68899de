"""Pose lists: random configurations within the joint limits, or joint values from a CSV file.

Every pose is measured on every key the device reads at a pose (each tracker
target; each theodolite station and target); keys where the instrument cannot
read the target are dropped. A theodolite scale bar is sighted from every
station and its length enters once. A ball-bar's pose file names the bar of each
pose (pivot, sphere, extension columns, as ``armcal plan`` writes them); a pose
whose length falls outside the LVDT travel is dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armcal.dataio.reader import read_pose_file
from armcal.devices.base import DeviceModel, Key
from armcal.devices.theodolite import BAR_ENDS
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures.plan import Plan
from armcal.spec.device import Theodolite, Tracker
from armcal.spec.model import Spec
from armcal.spec.procedure import Poses

BAR_SIGHTINGS = 3  # repeated sightings of each scale-bar mark per station


def pose_keys(device_spec) -> list[Key]:
    """The keys read at every pose."""
    if isinstance(device_spec, Theodolite):
        return [(station, target) for station in device_spec.stations for target in device_spec.targets]
    if isinstance(device_spec, Tracker):
        return [(target,) for target in device_spec.targets]
    raise ValueError(f"a poses procedure needs a tracker or theodolite, not {device_spec.type}")


def plan_poses(procedure: Poses, kinematics: KinematicModel, device: DeviceModel, spec: Spec, spec_dir: Path) -> Plan:
    device_spec = spec.device
    if procedure.file is not None:
        Q, file_keys = read_pose_file(spec_dir / procedure.file, spec)
        if file_keys is not None:
            return _keyed_poses(Q, file_keys, kinematics, device)
    else:
        rng = np.random.default_rng(procedure.seed)
        Q = rng.uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (procedure.count, kinematics.dof))
    keys: list[Key] = []
    rows: list[np.ndarray] = []
    dropped: dict[str, int] = {}
    for key in pose_keys(device_spec):
        visible = device.visible(key, kinematics.target_poses(device.target(key), Q))
        keys += [key] * int(visible.sum())
        rows.append(Q[visible])
        if (~visible).any():
            dropped[f"{'/'.join(key)} not visible"] = int((~visible).sum())
    plan = Plan(tuple(keys), np.concatenate(rows), dropped)
    bar = scale_bar_sightings(device_spec, kinematics.dof)
    return plan if bar is None else Plan.join([plan, bar])


def scale_bar_sightings(device_spec, dof: int) -> Plan | None:
    """A theodolite's scale-bar marks, sighted BAR_SIGHTINGS times from every station (no robot pose); None without a bar."""
    if not isinstance(device_spec, Theodolite) or device_spec.scale_bar is None:
        return None
    bar_keys = [(station, end) for station in device_spec.stations for end in BAR_ENDS] * BAR_SIGHTINGS
    return Plan(tuple(bar_keys), np.zeros((len(bar_keys), dof)))


def _keyed_poses(Q: np.ndarray, keys: tuple[Key, ...], kinematics: KinematicModel, device: DeviceModel) -> Plan:
    """Poses each read with its own key (a ball-bar's pose file), in the file's order; unreadable ones dropped."""
    keep = np.zeros(len(Q), dtype=bool)
    dropped: dict[str, int] = {}
    for key in dict.fromkeys(keys):
        rows = np.flatnonzero([k == key for k in keys])
        keep[rows] = device.visible(key, kinematics.target_poses(device.target(key), Q[rows]))
        if not keep[rows].all():
            dropped[f"{'-'.join(k for k in key if k)} not readable"] = int((~keep[rows]).sum())
    return Plan(tuple(k for k, ok in zip(keys, keep) if ok), Q[keep], dropped)
