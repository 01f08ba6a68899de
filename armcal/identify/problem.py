"""The least-squares problem: weighted residuals of all samples and their exact Jacobian.

theta = [robot parameters; device parameters]. Each sample contributes one
residual per reading, (predicted - measured) / sigma with sigma from the
device's noise model (angles wrapped to [-pi, pi]). The samples of each key are
evaluated by one mapped call of a compiled function (identify/compiled.py) that
also returns the exact Jacobian, from automatic differentiation of the
measurement function (never finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel, Key
from armcal.devices.theodolite import BAR_LENGTH, TheodoliteModel
from armcal.identify.compiled import compiled
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterInfo, ParameterSet


@dataclass(frozen=True)
class Residual:
    """Where each residual comes from: sample index, reading, key."""

    sample: np.ndarray  # (M,) index into the measurements (-1 for spec pseudo-observations)
    channel: tuple[str, ...]  # (M,)
    kind: tuple[str, ...]  # (M,) length | angle
    key: tuple[Key, ...]  # (M,)
    sigma: np.ndarray  # (M,) in the reading's internal unit
    measured: np.ndarray  # (M,)


@dataclass(frozen=True)
class _Group:
    """The samples of one key: a mapped Function (q, p, pd) -> (readings, d readings / d theta)."""

    function: ca.Function
    Q: np.ndarray  # (N, n)
    measured: np.ndarray  # (N, m)
    sigma: np.ndarray  # (N, m)
    angle: np.ndarray  # (m,) bool: wrap the difference
    valid: np.ndarray  # (N, m) bool


@dataclass(frozen=True)
class Problem:
    parameters: ParameterSet  # robot then device parameters
    n_robot: int
    groups: tuple[_Group, ...]
    residuals: Residual

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (M,) and their Jacobian (M, len(theta)); one mapped call per key."""
        theta = np.asarray(theta, dtype=float)
        p, pd = theta[: self.n_robot], theta[self.n_robot :]
        rs, Js = [], []
        for group in self.groups:
            y, dy = group.function(group.Q.T, p, pd)
            count, m = group.measured.shape
            difference = np.array(y).T - group.measured  # (N, m)
            difference[:, group.angle] = np.arctan2(np.sin(difference[:, group.angle]), np.cos(difference[:, group.angle]))
            jacobian = np.array(dy).reshape(m, count, len(theta)).transpose(1, 0, 2)  # (N, m, n_theta)
            for c in range(m):  # residuals ordered by reading, then sample
                rows = group.valid[:, c]
                rs.append(difference[rows, c] / group.sigma[rows, c])
                Js.append(jacobian[rows, c, :] / group.sigma[rows, c, None])
        return np.concatenate(rs), np.concatenate(Js)

    def predicted(self, theta: np.ndarray) -> np.ndarray:
        """Predicted readings (M,) in internal units."""
        r, _ = self.evaluate(theta)
        return self.residuals.measured + r * self.residuals.sigma


def combined_parameters(kinematics: KinematicModel, device: DeviceModel) -> ParameterSet:
    return ParameterSet(kinematics.parameters.entries + device.parameters.entries)


def _value_and_jacobian(kinematics: KinematicModel, device: DeviceModel, key: Key) -> ca.Function:
    """(q, p, pd) -> (readings, d readings / d [p; pd]) of one sample of a key."""
    h = device.measurement_function(kinematics, key)
    q, p, pd = (ca.SX.sym(n, h.size1_in(i)) for i, n in enumerate(("q", "p", "pd")))
    y = h(q, p, pd)
    return ca.Function("hj", [q, p, pd], [y, ca.jacobian(y, ca.vertcat(p, pd))])


def build_problem(kinematics: KinematicModel, device: DeviceModel, data: Measurements) -> Problem:
    """Assemble residuals of all samples of ``data`` (already prepared by the device)."""
    parameters = combined_parameters(kinematics, device)
    groups, samples, channels, kinds, keys, sigmas, measured = [], [], [], [], [], [], []
    key_rows = data.groups()
    if isinstance(device, TheodoliteModel) and device.spec.scale_bar is not None:
        key_rows[BAR_LENGTH] = np.array([-1])
    canonical = sorted(key_rows, key=str)  # one library serves every data set with the same keys
    identity = f"{kinematics.identity}|{device.identity}|{[str(k) for k in canonical]}"
    functions = dict(zip(canonical, compiled([_value_and_jacobian(kinematics, device, k) for k in canonical], identity)))
    for key, rows in key_rows.items():
        function = functions[key]
        key_channels = device.channels(key)
        if key == BAR_LENGTH:  # the bar's calibrated length, a pseudo-observation from the spec
            y = np.array([[device.spec.scale_bar.length]])
            Q = np.zeros((1, kinematics.dof))
        else:
            y = np.stack([data.readings[c.name][rows] for c in key_channels], axis=1)
            Q = np.nan_to_num(data.q[rows])
        sigma = device.sigma(key, y)
        valid = ~np.isnan(y)
        angle = np.array([c.kind == "angle" for c in key_channels])
        groups.append(_Group(function.map(len(rows)), Q, y, sigma, angle, valid))
        for c, channel in enumerate(key_channels):
            ok = valid[:, c]
            samples.append(rows[ok])
            channels += [channel.name] * int(ok.sum())
            kinds += [channel.kind] * int(ok.sum())
            keys += [key] * int(ok.sum())
            sigmas.append(sigma[ok, c])
            measured.append(y[ok, c])
    residual = Residual(
        sample=np.concatenate(samples),
        channel=tuple(channels),
        kind=tuple(kinds),
        key=tuple(keys),
        sigma=np.concatenate(sigmas),
        measured=np.concatenate(measured),
    )
    return Problem(parameters, len(kinematics.parameters), tuple(groups), residual)


def with_values(parameters: ParameterSet, values: np.ndarray) -> ParameterSet:
    """The same parameters with new nominal values (e.g. identified ones)."""
    return ParameterSet(
        tuple(ParameterInfo(e.name, e.kind, float(v), e.free, e.lower, e.upper) for e, v in zip(parameters.entries, values))
    )
