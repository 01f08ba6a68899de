"""The measurement model h(q, x, p, pd, pe) = instrument(chain(q)) with every effect, composed in this one place from
the robot's chain (kinematics/), the effects' terms (effects/measurement.py) and the instrument's geometry (devices/).

Per sample it takes the joint readings q and the extras x (effects/measurement.py's ``extras_matrix``), the robot's
parameters p, the instrument's pd and the effects' pe.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.devices.base import DeviceModel, Key
from armcal.effects.measurement import EffectSet, extras_size
from armcal.kinematics.compiler import KinematicModel


def measurement_function(kinematics: KinematicModel, device: DeviceModel, key: Key, effects: EffectSet = EffectSet()) -> ca.Function:
    """h(q, x, p, pd, pe): the device's readings of a key's target, with every effect."""
    n = kinematics.dof
    q, x = ca.SX.sym("q", n), ca.SX.sym("x", extras_size(n))
    p, pd = ca.SX.sym("p", len(kinematics.parameters)), ca.SX.sym("pd", len(device.parameters))
    pe = ca.SX.sym("pe", len(effects.parameters))
    v = effects.parameters.symbols(pe)
    target = device.target(key)
    if target is None:
        pose = ca.SX.eye(4)
    else:
        qv, pv = effects.joint_values(kinematics, q, x, p, v), effects.robot_parameters(kinematics, x, p, v)
        pose = effects.bent(kinematics, kinematics.target_links[target], qv, pv, kinematics.targets[target](qv, pv), v)
    y = device.geometry(key)(pose, effects.device_parameters(device.parameters, pd, v))
    return ca.Function("h", [q, x, p, pd, pe], [effects.readings(device.channels(key), y, v)], ["q", "x", "p", "pd", "pe"], ["y"])


def predict(
    kinematics: KinematicModel, device: DeviceModel, key: Key, Q: np.ndarray, p: np.ndarray | None = None, pd: np.ndarray | None = None
) -> np.ndarray:
    """Readings (N, channels) of N samples of one key, one mapped call of h with no effects; p and pd default to the
    nominal values."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if len(Q) == 0:
        return np.zeros((0, len(device.channels(key))))
    p = kinematics.parameter_vector(p)
    pd = device.parameters.nominal if pd is None else np.asarray(pd, dtype=float)
    mapped = measurement_function(kinematics, device, key).map(len(Q))
    return np.array(mapped(Q.T, np.zeros((extras_size(kinematics.dof), len(Q))), p, pd, np.zeros(0))).T
