"""Effects as symbolic terms of the measurement model.

Per sample the model takes extras x = [dir_1..dir_n, t, temperature] besides
the joint readings q. Joint-side effects add to the joint value the chain sees:
encoder scale s q, gear harmonic A sin(h r q) + B cos(h r q) (Whitney &
Lozinski's transmission error), backlash w dir, compliance c tau_g(q) with tau_g
the gravity torque about the joint from lumped link masses. Thermal drift scales
every length of the robot by 1 + k (T - T_ref) (or 1 + k t). Instrument-side:
a scale on length readings, a bias on one microphone's range, an offset of the
ball-bar's length, a displacement of one pivot.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from armcal.devices.base import DeviceModel, Key, symbols
from armcal.effects.library import EffectSpec, LumpedMass
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet

GRAVITY = (0.0, 0.0, -9.81)  # m/s^2 in the robot base frame (z up)
DEFAULT_LINK_MASS = 5.0  # kg at each link frame's origin when an effect names no masses


def extras_size(dof: int) -> int:
    return dof + 2


def extras_matrix(extras: dict, count: int, dof: int, reference_temperature: float = 20.0) -> np.ndarray:
    """(N, n+2) rows [dir_1..dir_n, t, temperature] from a data set's optional columns."""
    out = np.zeros((count, extras_size(dof)))
    if "dir" in extras:
        out[:, :dof] = extras["dir"]
    if "t" in extras:
        out[:, dof] = extras["t"]
    out[:, dof + 1] = extras.get("temperature", np.full(count, reference_temperature))
    return np.nan_to_num(out)


def _gravity_torque(frames: ca.SX, joint: int, masses, dof: int) -> ca.SX:
    """Gravity torque (N m) about joint ``joint`` (z of F_{joint-1}) from the masses on links joint..n."""
    frame = lambda k: frames[:, 4 * k : 4 * k + 4]  # noqa: E731
    axis, origin = frame(joint - 1)[:3, 2], frame(joint - 1)[:3, 3]
    masses = masses or [LumpedMass(k, DEFAULT_LINK_MASS, (0.0, 0.0, 0.0)) for k in range(joint, dof + 1)]
    torque = 0
    for mass in masses:
        if mass.link < joint:
            continue
        centre = ca.mtimes(frame(mass.link), ca.vertcat(*mass.centre, 1))[:3]
        lever = (centre - origin) / 1000.0  # m
        torque += ca.dot(axis, ca.cross(lever, mass.mass * ca.DM(GRAVITY)))
    return torque


@dataclass(frozen=True)
class EffectSet:
    """The effects in a model and their parameter vector pe."""

    effects: tuple[EffectSpec, ...] = ()

    @property
    def parameters(self) -> ParameterSet:
        return ParameterSet(tuple(p for e in self.effects for p in e.parameters()))

    @property
    def identity(self) -> str:
        return repr(self.effects)

    def joint_values(self, kinematics: KinematicModel, q, x, p, v: dict):
        """q + the joint-side effects' deviations; ``v`` maps effect parameter names to symbols."""
        n = kinematics.dof
        delta = [0] * n
        frames = None
        for e in self.effects:
            if e.joint is None:
                continue
            j, value = e.joint - 1, lambda f, e=e: v[f"{e.id}.{f}"]  # noqa: E731
            if e.type == "encoder_scale":
                delta[j] += value("scale") * q[j]
            elif e.type == "gear_harmonic":
                phase = e.order * e.ratio * q[j]
                delta[j] += value("sin") * ca.sin(phase) + value("cos") * ca.cos(phase)
            elif e.type == "backlash":
                delta[j] += value("half_width") * x[j]
            elif e.type == "joint_compliance":
                frames = kinematics.frames(q, p) if frames is None else frames
                delta[j] += value("compliance") * _gravity_torque(frames, e.joint, e.masses, n)
        return q + ca.vertcat(*delta)

    def length_factor(self, x, v: dict, dof: int):
        """1 + thermal drift of the robot's lengths."""
        factor = 1
        for e in self.effects:
            if e.type == "thermal_drift":
                change = x[dof + 1] - e.reference_temperature if e.source == "temperature" else x[dof]
                factor += v[f"{e.id}.coefficient"] * change
        return factor

    def robot_parameters(self, kinematics: KinematicModel, x, p, v: dict):
        """p with every length scaled by the thermal factor."""
        lengths = ca.DM([1.0 if e.kind == "length" else 0.0 for e in kinematics.parameters.entries])
        return p + (self.length_factor(x, v, kinematics.dof) - 1) * (p * lengths)

    def device_parameters(self, device: DeviceModel, pd, v: dict):
        """pd with pivot offsets added."""
        shift = [0] * len(device.parameters)
        for e in self.effects:
            if e.type == "pivot_offset":
                for c in "xyz":
                    shift[device.parameters.index(f"pivot.{e.pivot}.{c}")] = v[f"{e.id}.{c}"]
        return pd + ca.vertcat(*shift)

    def readings(self, device: DeviceModel, key: Key, y, v: dict):
        """Readings with the instrument-side effects: scale, range bias, ball-bar length offset."""
        channels = device.channels(key)
        parts = [y[i] for i in range(len(channels))]
        for e in self.effects:
            if e.type == "sensor_scale":
                parts = [r * (1 + v[f"{e.id}.scale"]) if c.kind == "length" else r for r, c in zip(parts, channels)]
            elif e.type == "range_bias":
                parts = [r + v[f"{e.id}.bias"] if c.name == f"s_{e.microphone}" else r for r, c in zip(parts, channels)]
            elif e.type == "ballbar_length":
                parts = [r + v[f"{e.id}.offset"] for r in parts]
        return ca.vertcat(*parts)

    def measurement_function(self, kinematics: KinematicModel, device: DeviceModel, key: Key) -> ca.Function:
        """h(q, x, p, pd, pe): the device's readings of a key's target, with every effect."""
        n = kinematics.dof
        q, x = ca.SX.sym("q", n), ca.SX.sym("x", extras_size(n))
        p, pd = ca.SX.sym("p", len(kinematics.parameters)), ca.SX.sym("pd", len(device.parameters))
        pe = ca.SX.sym("pe", len(self.parameters))
        v = symbols(self.parameters, pe)
        target = device.target(key)
        if target is None:
            pose = ca.SX.eye(4)
        else:
            pose = kinematics.targets[target](self.joint_values(kinematics, q, x, p, v), self.robot_parameters(kinematics, x, p, v))
        y = device.geometry(key)(pose, self.device_parameters(device, pd, v))
        return ca.Function("h", [q, x, p, pd, pe], [self.readings(device, key, y, v)], ["q", "x", "p", "pd", "pe"], ["y"])

    def joint_deviation_function(self, kinematics: KinematicModel) -> ca.Function:
        """(q, x, p, pe) -> joint deviations and the thermal length factor, for the simulator."""
        n = kinematics.dof
        q, x = ca.SX.sym("q", n), ca.SX.sym("x", extras_size(n))
        p, pe = ca.SX.sym("p", len(kinematics.parameters)), ca.SX.sym("pe", len(self.parameters))
        v = symbols(self.parameters, pe)
        deviation = self.joint_values(kinematics, q, x, p, v) - q
        return ca.Function("effects", [q, x, p, pe], [deviation, self.length_factor(x, v, n)])

    def values(self) -> np.ndarray:
        """pe at the effects' own values (a simulation's hidden amplitudes)."""
        return self.parameters.nominal

    def reading_function(self, device: DeviceModel, key: Key) -> ca.Function:
        """(y, pe) -> readings with the instrument-side effects, for the simulator."""
        y = ca.SX.sym("y", len(device.channels(key)))
        pe = ca.SX.sym("pe", len(self.parameters))
        return ca.Function("readings", [y, pe], [self.readings(device, key, y, symbols(self.parameters, pe))])

    def device_parameter_function(self, device: DeviceModel) -> ca.Function:
        """(pd, pe) -> pd with pivot offsets, for the simulator."""
        pd = ca.SX.sym("pd", len(device.parameters))
        pe = ca.SX.sym("pe", len(self.parameters))
        return ca.Function("pivots", [pd, pe], [self.device_parameters(device, pd, symbols(self.parameters, pe))])


def gravity_torque_function(kinematics: KinematicModel) -> ca.Function:
    """(q, p) -> gravity torque (N m) about every joint from the default lumped masses, for the evidence plots."""
    q, p = ca.SX.sym("q", kinematics.dof), ca.SX.sym("p", len(kinematics.parameters))
    frames = kinematics.frames(q, p)
    torques = [_gravity_torque(frames, j, (), kinematics.dof) for j in range(1, kinematics.dof + 1)]
    return ca.Function("gravity_torque", [q, p], [ca.vertcat(*torques)])
